//! `host-sim config`: the default configuration, every key of the TOML
//! file.

use anyhow::Result;

use crate::config::SimConfig;

/// Arguments of `config` (none).
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Run `config`: print the defaults as TOML.
pub fn run(_args: &Args) -> Result<()> {
    print!("{}", SimConfig::default().to_toml());
    Ok(())
}
