//! `fuzzy-send`: see the `sender` library and `sender/README.md`.

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    let cli = sender::cli::Cli::parse();
    ExitCode::from(sender::cli::run(cli).code())
}
