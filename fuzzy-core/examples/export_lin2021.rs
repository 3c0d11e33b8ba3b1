//! Print Lin et al.'s controller as a MATLAB/Octave `.fis` file (or FCL with
//! `--fcl`): `cargo run -p fuzzy-core --example export_lin2021 > lin2021.fis`.

use fuzzy_core::fuzzy::export::{write_fcl, write_fis};
use fuzzy_core::lin2021::SYSTEM;

fn main() -> std::fmt::Result {
    let mut text = String::new();
    if std::env::args().any(|a| a == "--fcl") {
        write_fcl(&mut text, &SYSTEM)?;
    } else {
        write_fis(&mut text, &SYSTEM)?;
    }
    print!("{text}");
    Ok(())
}
