//! The board image's only memory-mapped I/O: a few fixed STM32F405 registers and the
//! stack-paint probe, behind a safe interface.
//!
//! Why `unsafe` here: reading and writing peripheral registers and unused RAM is raw-pointer
//! volatile access. It is confined to this module; the addresses are constants of this file
//! (the reference manual RM0090 memory map), never taken from callers, so the safe functions
//! cannot be made to touch anything else.
#![allow(unsafe_code)]

/// One 32-bit peripheral register at a fixed address of this module.
#[derive(Clone, Copy)]
pub struct Reg(usize);

impl Reg {
    /// Volatile read.
    pub fn read(self) -> u32 {
        // SAFETY: `self.0` is one of the aligned peripheral register addresses below, which
        // are always mapped on the STM32F405 (and in QEMU netduinoplus2).
        unsafe { core::ptr::read_volatile(self.0 as *const u32) }
    }

    /// Volatile write.
    pub fn write(self, v: u32) {
        // SAFETY: as in `read`; these registers have no memory-safety side effects.
        unsafe { core::ptr::write_volatile(self.0 as *mut u32, v) }
    }

    /// Read-modify-write: clears `clear`, then sets `set`.
    pub fn modify(self, clear: u32, set: u32) {
        self.write((self.read() & !clear) | set);
    }
}

/// RCC AHB1 peripheral clock enable (GPIOAEN = bit 0).
pub const RCC_AHB1ENR: Reg = Reg(0x4002_3830);
/// RCC APB2 peripheral clock enable (USART1EN = bit 4).
pub const RCC_APB2ENR: Reg = Reg(0x4002_3844);
/// GPIOA mode register.
pub const GPIOA_MODER: Reg = Reg(0x4002_0000);
/// GPIOA alternate function high register (pins 8..15).
pub const GPIOA_AFRH: Reg = Reg(0x4002_0024);

/// USART1 (0x4001_1000): QEMU netduinoplus2 connects the first `-serial` to it.
pub mod usart1 {
    use super::Reg;
    /// Status register.
    pub const SR: Reg = Reg(0x4001_1000);
    /// Data register.
    pub const DR: Reg = Reg(0x4001_1004);
    /// Baud rate register.
    pub const BRR: Reg = Reg(0x4001_1008);
    /// Control register 1.
    pub const CR1: Reg = Reg(0x4001_100C);
}

extern "C" {
    /// Start of the free RAM above `.bss`/`.uninit` (cortex-m-rt's linker script): the
    /// lowest address the stack can grow down to.
    static mut __sheap: u32;
    /// Initial stack pointer, top of RAM (cortex-m-rt's linker script).
    static mut _stack_start: u32;
}

/// The paint pattern of the unused stack.
const PAINT: u32 = 0xCAFE_F00D;
/// Bytes below the current stack pointer left unpainted (the painting code's own frame).
const PAINT_MARGIN: usize = 256;

fn stack_bounds() -> (usize, usize) {
    let bottom = core::ptr::addr_of!(__sheap) as usize;
    let top = core::ptr::addr_of!(_stack_start) as usize;
    (bottom, top)
}

/// Paints the unused stack (from the bottom of free RAM up to a margin below the current
/// stack pointer) with a pattern. Call once, early, with interrupts off.
pub fn paint_stack() {
    let (bottom, _) = stack_bounds();
    let sp = cortex_m::register::msp::read() as usize;
    let end = sp.saturating_sub(PAINT_MARGIN) & !3;
    let mut p = (bottom + 3) & !3;
    while p < end {
        // SAFETY: [bottom, sp - margin) is RAM that nothing uses: above all statics and
        // below the live stack, no heap, no interrupts enabled; word-aligned.
        unsafe { core::ptr::write_volatile(p as *mut u32, PAINT) };
        p += 4;
    }
}

/// Deepest stack use so far (bytes from the top of RAM), from the painted pattern.
pub fn stack_high_water() -> usize {
    let (bottom, top) = stack_bounds();
    let mut p = (bottom + 3) & !3;
    while p < top {
        // SAFETY: reads RAM between the statics and the top of the stack, word-aligned.
        let v = unsafe { core::ptr::read_volatile(p as *const u32) };
        if v != PAINT {
            break;
        }
        p += 4;
    }
    top.saturating_sub(p)
}

/// Bytes between the end of the statics and the top of RAM (what the stack may use).
pub fn stack_capacity() -> usize {
    let (bottom, top) = stack_bounds();
    top.saturating_sub(bottom)
}
