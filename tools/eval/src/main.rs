//! `plumbline-eval`: accuracy evaluation against the simulator's truth, one subcommand per area. The
//! timing benches (`cargo bench`) measure speed only; everything that scores results against the truth of a
//! synthetic campaign lives here.
//!
//! - `registration`: the MM↔aerial registration per GNSS profile in the form of Jende et al. (2017) Table 1,
//!   with every diagnosis against the truth (module [`registration`]);
//!   `cargo run --release -p plumbline-eval -- registration [--preset district] [--realism harsh] …`.
//! - `rejections DIR [VARIANT...] [--dump FILE]`: what the adjustment rejects on a finished simulated
//!   campaign (a `plumbline demo` folder), every observation scored against the truth (module
//!   [`rejections`]).
//! - `navigation [--seed N] [--without NAME ...]`: the global adjustment on `district`-sized drives with
//!   observations simulated from the truth, in the table form of Meyer et al. (2023) (module
//!   [`navigation`]).
//!
//! - `lines [--preset district] [--missed] [--dump DIR]`: road-marking extraction and assembly with the
//!   true poses against the simulator's markings, the trajectory taken out (module [`lines`]).
//!
//! - `poles [--cloud-only] [--missed] …`: pole recall, matching precision and the coordinate updates' χ² on
//!   a `district` drive, depth camera and roof laser scanner (module [`poles`]).
//!
//! `cargo run --release -p plumbline-eval -- help SUBCOMMAND` lists each one's flags. None of it runs in CI.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

mod lines;
mod navigation;
mod poles;
mod registration;
mod rejections;

use clap::{Parser, Subcommand};

/// Accuracy evaluation of plumbline against the simulator's truth.
#[derive(Debug, Parser)]
#[command(name = "plumbline-eval", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Registration accuracy per GNSS profile on a synthetic campaign (Jende et al. 2017, Table 1).
    Registration(registration::Args),
    /// What the adjustment rejects on a finished simulated campaign, scored against its truth.
    Rejections(rejections::Args),
    /// Road-marking extraction with the true poses against the simulator's markings.
    Lines(lines::Args),
    /// The global adjustment's accuracy on district drives with observations simulated from the truth.
    Navigation(navigation::Args),
    /// Pole detection and matching on a district drive (depth camera and roof laser scanner) against the truth.
    Poles(poles::Args),
}

fn main() {
    match Cli::parse().command {
        Command::Registration(args) => registration::main(&args),
        Command::Rejections(args) => rejections::main(&args),
        Command::Lines(args) => lines::main(&args),
        Command::Navigation(args) => navigation::main(&args),
        Command::Poles(args) => poles::main(&args),
    }
}
