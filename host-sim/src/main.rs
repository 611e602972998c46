//! `flexcal`: the desktop tool. Each subcommand lives in `cmd/`.

use clap::{Parser, Subcommand};
use flexcal_sim::cmd;

#[derive(Parser)]
#[command(
    name = "flexcal",
    version,
    about = "Slave INS calibration against a master INS, with flexure and dynamic lever arm"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate a scenario and write a recording (format v1, with truth.csv).
    Simulate(cmd::simulate::Args),
    /// Calibrate a recording: summary.json, estimates.csv and plots.
    Calibrate(cmd::calibrate::Args),
    /// Monte Carlo runs of a scenario: RMS errors, mean σ, NEES with its χ² band.
    Montecarlo(cmd::montecarlo::Args),
    /// The paper's figures 4 and 5: bias estimates with and without dynamic lever-arm compensation.
    PaperFigures(cmd::paper_figures::Args),
    /// Identify an AR flexure model (order by AIC/BIC, Ljung-Box check).
    Identify(cmd::identify::Args),
    /// Replay a recording through the board firmware in QEMU: summary.json, estimates.csv.
    Replay(cmd::replay::Args),
    /// The board's cost in QEMU -icount: instructions per master update by phase, stack, flash.
    BenchBoard(cmd::bench_board::Args),
    /// Find structure left in the residuals, name the effect, add it: diagnosis.json, report.md.
    Diagnose(cmd::diagnose::Args),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Simulate(a) => cmd::simulate::run(&a),
        Command::Calibrate(a) => cmd::calibrate::run(&a),
        Command::Montecarlo(a) => cmd::montecarlo::run(&a),
        Command::Identify(a) => cmd::identify::run(&a),
        Command::PaperFigures(a) => cmd::paper_figures::run(&a),
        Command::Replay(a) => cmd::replay::run(&a),
        Command::Diagnose(a) => cmd::diagnose::run(&a),
        Command::BenchBoard(a) => cmd::bench_board::run(&a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("flexcal: error: {e}");
            std::process::ExitCode::FAILURE
        }
    }
}
