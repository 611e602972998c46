//! `flexcal bench-board --out DIR [--elf PATH]`: the board's cost benchmark
//! (`docs/performance.md`). Simulates `moored` and `paper` (10 s each, seed 1), replays
//! them through the firmware image in QEMU under `-icount shift=0` for three layouts
//! (declared 21 states; `gyro_scale_factor`, 24 states in the 33-state engine;
//! `gyro_g_sensitivity` + `lever_arm_error`, all 33), each twice: once timing every byte
//! (instructions per master update, stack high-water) and once with the board's sampling
//! profiler (the split by phase). Prints one table, and the image's flash and static RAM
//! from its ELF section headers.
//!
//! It fails only when the image does not fit the chip (flash or RAM of the STM32F405) or a
//! run fails; the targets are printed beside the figures, never enforced here.

use crate::cmd::common::{ModelArgs, ScenarioArgs};
use crate::cmd::replay::{self, Transport, DEFAULT_ELF};
use crate::cmd::simulate;
use std::path::{Path, PathBuf};

/// Arguments of `flexcal bench-board`.
#[derive(clap::Args)]
pub struct Args {
    /// Working directory (recordings, configurations, replay outputs).
    #[arg(long)]
    pub out: PathBuf,
    /// Firmware image (default: the `cargo fw-build` output).
    #[arg(long)]
    pub elf: Option<PathBuf>,
}

/// The STM32F405's flash (bytes).
const CHIP_FLASH: u64 = 1024 * 1024;
/// The STM32F405's main SRAM (bytes; `memory.x`).
const CHIP_RAM: u64 = 128 * 1024;

/// One layout measured: its name, recording, effects, and the targets (whole
/// update in instructions, RAM in bytes).
struct Layout {
    name: &'static str,
    scenario: &'static str,
    effects: &'static [&'static str],
    target_instructions: f64,
    target_ram: u64,
}

const LAYOUTS: [Layout; 3] = [
    Layout {
        name: "moored, declared (21)",
        scenario: "moored",
        effects: &[],
        target_instructions: 60e3,
        target_ram: 32 * 1024,
    },
    Layout {
        name: "paper, gyro_scale_factor (24 in 33)",
        scenario: "paper",
        effects: &["gyro_scale_factor"],
        target_instructions: 100e3,
        target_ram: 48 * 1024,
    },
    Layout {
        name: "paper, gyro_g_sensitivity + lever_arm_error (33)",
        scenario: "paper",
        effects: &["gyro_g_sensitivity", "lever_arm_error"],
        target_instructions: 100e3,
        target_ram: 48 * 1024,
    },
];

/// Phases of the profile, in the order printed.
const PHASES: [&str; 8] = [
    "link",
    "engine",
    "strapdown",
    "matching",
    "phi-q",
    "predict",
    "update",
    "identifier",
];

/// Runs `flexcal bench-board`.
pub fn run(a: &Args) -> Result<(), String> {
    let elf = a.elf.clone().unwrap_or_else(|| PathBuf::from(DEFAULT_ELF));
    let (flash, statics) = image_sizes(&elf)?;
    std::fs::create_dir_all(&a.out).map_err(|e| format!("{}: {e}", a.out.display()))?;
    for scenario in ["moored", "paper"] {
        simulate::run(&simulate::Args {
            scenario: ScenarioArgs {
                scenario: Some(scenario.to_string()),
                blind: false,
                effect: Vec::new(),
                duration: Some(10.0),
                seed: 1,
            },
            out: a.out.join(scenario),
            drawn: None,
            clock_offset: None,
            mounting_deg: None,
            master_steps: Default::default(),
        })?;
    }
    println!(
        "\n| layout | instructions per master update (target) | {} | predict + updates | stack high-water | RAM = statics + stack (target) |",
        PHASES.join(" | ")
    );
    println!("|---|---:|{}---:|---:|---:|", "---:|".repeat(PHASES.len()));
    let mut over_chip = Vec::new();
    for layout in &LAYOUTS {
        let rec = a.out.join(layout.scenario);
        let cfg = config_with_effects(&rec, layout.effects, &a.out)?;
        let total = measure(&elf, &rec, &cfg, &a.out, false)?;
        let split = measure(&elf, &rec, &cfg, &a.out, true)?;
        let get = |k: &str| split.cost.iter().find(|(n, _)| n == k).map_or(0.0, |c| c.1);
        let instructions = total.cost.first().map_or(0.0, |c| c.1);
        let ram = statics + total.stack;
        if ram > CHIP_RAM {
            over_chip.push(format!("{}: RAM {ram} B > {CHIP_RAM} B", layout.name));
        }
        let phases: Vec<String> = PHASES.iter().map(|p| kilo(get(p))).collect();
        println!(
            "| {} | {} ({}) | {} | {} | {} B | {} B ({} B) |",
            layout.name,
            kilo(instructions),
            kilo(layout.target_instructions),
            phases.join(" | "),
            kilo(get("phi-q") + get("predict") + get("update")),
            total.stack,
            ram,
            layout.target_ram
        );
    }
    println!(
        "\nimage {}: flash {flash} B (target {} B, chip {CHIP_FLASH} B), statics {statics} B",
        elf.display(),
        128 * 1024
    );
    println!(
        "(instructions: SysTick ticks / {} under -icount shift=0; phases from the sampling \
         profiler, one sample per `profile-period-ticks` ticks: their sum is the total to \
         within the sampling)",
        replay::TICKS_PER_INSTRUCTION
    );
    if flash > CHIP_FLASH {
        over_chip.push(format!("flash {flash} B > {CHIP_FLASH} B"));
    }
    if over_chip.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the image does not fit the chip: {}",
            over_chip.join("; ")
        ))
    }
}

fn kilo(x: f64) -> String {
    format!("{:.1}k", x / 1e3)
}

/// What one replay measured.
struct Measured {
    cost: Vec<(String, f64)>,
    stack: u64,
}

fn measure(
    elf: &Path,
    rec: &Path,
    cfg: &Path,
    dir: &Path,
    profile: bool,
) -> Result<Measured, String> {
    let name = format!(
        "r-{}-{}",
        cfg.file_stem()
            .map_or("cfg".into(), |s| s.to_string_lossy()),
        if profile { "profile" } else { "icount" }
    );
    // The outputs directory holds the semihosting link files only.
    let args = replay::Args {
        rec_dir: rec.to_path_buf(),
        qemu: true,
        out: dir.join(name),
        elf: Some(elf.to_path_buf()),
        config: Some(cfg.to_path_buf()),
        estimates_every: 1,
        status_every: 1000,
        transport: Transport::Semihosting,
        icount: true,
        profile,
        timeout_s: 600,
        model: ModelArgs::default(),
    };
    let r = replay::replay(&args)?;
    Ok(Measured {
        cost: replay::cost_per_update(&r.qemu).ok_or("no cost figures from the firmware")?,
        stack: r.qemu.metric("stack-high-water-bytes").unwrap_or(0),
    })
}

/// The recording's declared configuration with `effects` in place of `effects = []`,
/// written beside the outputs.
fn config_with_effects(rec: &Path, effects: &[&str], dir: &Path) -> Result<PathBuf, String> {
    let declared = rec.join("calibrate.toml");
    let text =
        std::fs::read_to_string(&declared).map_err(|e| format!("{}: {e}", declared.display()))?;
    let list: Vec<String> = effects.iter().map(|e| format!("\"{e}\"")).collect();
    let line = format!("effects = [{}]", list.join(", "));
    if !text.lines().any(|l| l == "effects = []") {
        return Err(format!("{}: no `effects = []` line", declared.display()));
    }
    let out = text
        .lines()
        .map(|l| {
            if l == "effects = []" {
                line.as_str()
            } else {
                l
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    let stem = rec
        .file_name()
        .map_or("rec".into(), |s| s.to_string_lossy());
    let path = dir.join(format!("{stem}-{}.toml", effects.len()));
    std::fs::write(&path, out + "\n").map_err(|e| format!("{}: {e}", path.display()))?;
    Ok(path)
}

/// Flash (bytes loaded into flash: vector table, text, read-only data, initialized data)
/// and static RAM (data, bss, uninit) of an ELF32 little-endian image, from its section
/// headers.
fn image_sizes(elf: &Path) -> Result<(u64, u64), String> {
    let b = std::fs::read(elf)
        .map_err(|e| format!("{}: {e} (build it with `cargo fw-build`)", elf.display()))?;
    let u16_at = |o: usize| {
        let s: [u8; 2] = b.get(o..o + 2)?.try_into().ok()?;
        Some(u64::from(u16::from_le_bytes(s)))
    };
    let u32_at = |o: usize| {
        let s: [u8; 4] = b.get(o..o + 4)?.try_into().ok()?;
        Some(u64::from(u32::from_le_bytes(s)))
    };
    let bad = || format!("{}: not an ELF32 little-endian image", elf.display());
    if b.get(..6) != Some(&[0x7f, b'E', b'L', b'F', 1, 1][..]) {
        return Err(bad());
    }
    let shoff = u32_at(0x20).ok_or_else(bad)? as usize;
    let shentsize = u16_at(0x2e).ok_or_else(bad)? as usize;
    let shnum = u16_at(0x30).ok_or_else(bad)? as usize;
    let shstrndx = u16_at(0x32).ok_or_else(bad)? as usize;
    let header = |i: usize| shoff + i * shentsize;
    let strtab = u32_at(header(shstrndx) + 0x10).ok_or_else(bad)? as usize;
    let name_of = |i: usize| -> Option<String> {
        let off = strtab + u32_at(header(i))? as usize;
        let end = b.get(off..)?.iter().position(|&c| c == 0)? + off;
        Some(String::from_utf8_lossy(b.get(off..end)?).into_owned())
    };
    let (mut flash, mut ram) = (0, 0);
    for i in 0..shnum {
        let name = name_of(i).ok_or_else(bad)?;
        let size = u32_at(header(i) + 0x14).ok_or_else(bad)?;
        match name.as_str() {
            ".vector_table" | ".text" | ".rodata" => flash += size,
            ".data" => {
                flash += size;
                ram += size;
            }
            ".bss" | ".uninit" => ram += size,
            _ => {}
        }
    }
    Ok((flash, ram))
}
