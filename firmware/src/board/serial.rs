//! USART1 by polling: RX when SR.RXNE is set, TX when SR.TXE is set. No interrupts, no DMA:
//! the replay loop has nothing else to do while it waits for the next byte.
//!
//! Pins (real board): PA9 = TX, PA10 = RX, alternate function 7. Clock: the reset clock
//! (HSI, 16 MHz) on APB2; `BRR` for 460 800 baud (the link's recommended rate) is
//! 16 MHz / 460 800 = 34.7 → mantissa 2, fraction 3 (/16), i.e. `0x23`. QEMU ignores the
//! baud rate and the RCC/GPIO writes.

use super::hw::{self, usart1};

const SR_ORE: u32 = 1 << 3;
const SR_RXNE: u32 = 1 << 5;
const SR_TXE: u32 = 1 << 7;
const CR1_RE: u32 = 1 << 2;
const CR1_TE: u32 = 1 << 3;
const CR1_UE: u32 = 1 << 13;
/// 460 800 baud at 16 MHz APB2 (oversampling by 16).
const BRR_460800_AT_16MHZ: u32 = 0x23;

/// USART1, enabled for RX and TX.
pub struct Serial {
    overruns: u32,
}

impl Serial {
    /// Clocks, pins and the USART itself.
    pub fn init() -> Self {
        hw::RCC_AHB1ENR.modify(0, 1 << 0);
        hw::RCC_APB2ENR.modify(0, 1 << 4);
        // PA9, PA10: alternate function mode (0b10), AF7.
        hw::GPIOA_MODER.modify(0b1111 << 18, 0b1010 << 18);
        hw::GPIOA_AFRH.modify(0xFF << 4, 0x77 << 4);
        usart1::BRR.write(BRR_460800_AT_16MHZ);
        usart1::CR1.write(CR1_UE | CR1_TE | CR1_RE);
        Self { overruns: 0 }
    }

    /// The next received byte, if one is waiting.
    pub fn try_read(&mut self) -> Option<u8> {
        let sr = usart1::SR.read();
        if sr & SR_ORE != 0 {
            // Overrun: a byte was lost (real hardware only; QEMU holds the sender back).
            // Reading DR after SR clears the flag; the link's CRC rejects the damaged frame.
            self.overruns = self.overruns.wrapping_add(1);
        }
        if sr & SR_RXNE != 0 {
            Some((usart1::DR.read() & 0xFF) as u8)
        } else {
            None
        }
    }

    /// Sends `bytes`, waiting for TXE before each.
    pub fn write_all(&mut self, bytes: &[u8]) {
        for b in bytes {
            while usart1::SR.read() & SR_TXE == 0 {}
            usart1::DR.write(u32::from(*b));
        }
    }

    /// Receive overruns seen (bytes lost on the line).
    pub fn overruns(&self) -> u32 {
        self.overruns
    }
}
