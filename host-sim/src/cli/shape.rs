//! `host-sim shape`: one of the paper's test shapes as CSV.

use anyhow::Result;

use crate::shapes;

/// Arguments of `shape`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Which shape.
    #[arg(value_enum)]
    pub shape: shapes::Shape,
}

/// Run `shape`: print the points.
pub fn run(args: &Args) -> Result<()> {
    println!(
        "# {} (Lin et al. 2021), 2001 points, u step 0.0005\nx,y,z",
        args.shape.name()
    );
    for p in args.shape.points() {
        println!("{:.9},{:.9},{:.9}", p[0], p[1], p[2]);
    }
    Ok(())
}
