//! Stream a path to a running firmware over TCP (the firmware's `cargo run`
//! puts QEMU's USART1 on `tcp::7878`) and print the feeds it schedules.
//!
//! ```text
//! cargo run -p system-tests --bin stream -- PATH.csv [--addr 127.0.0.1:7878] [--f-max 3000] [--f-min 60]
//! ```
//!
//! Output: CSV `seq,index,feed_mm_per_min`, then the final status on stderr.
//! A development aid for the QEMU image; it speaks the same link client
//! (`link::client`) as the system tests.

use std::net::TcpStream;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::Parser;
use fuzzy_core::units::FeedMmPerMin;
use link::client::Connection;
use link::{DeviceMsg, Motion};

/// Stream a CSV path (`x,y,z[,feed cap]`, mm, mm/min) to the firmware.
#[derive(Parser)]
struct Args {
    /// The path.
    path: PathBuf,
    /// The firmware's link (QEMU's USART1).
    #[arg(long, default_value = "127.0.0.1:7878")]
    addr: String,
    /// Largest scheduled feed, mm/min.
    #[arg(long, default_value_t = 3000.0)]
    f_max: f64,
    /// Smallest scheduled feed, mm/min.
    #[arg(long, default_value_t = 60.0)]
    f_min: f64,
    /// Give up after this many seconds.
    #[arg(long, default_value_t = 3600)]
    timeout_s: u64,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("stream: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<()> {
    let pts = host_sim::path_csv::read(&args.path)?;
    let stream =
        TcpStream::connect(&args.addr).with_context(|| format!("connecting to {}", args.addr))?;
    let reader = stream.try_clone()?;
    let mut conn = Connection::new(Box::new(stream), Box::new(reader));
    let timeout = Duration::from_secs(args.timeout_s);
    let mut scheduled = Vec::new();
    let mut seen = |m: &DeviceMsg| {
        if let DeviceMsg::Scheduled {
            seq,
            index,
            feed_mm_per_min,
            ..
        } = *m
        {
            scheduled.push((seq, index, feed_mm_per_min));
        }
    };
    // The hello went out at reset: continue the sequence where it is.
    let s = conn.status(20, &mut seen)?;
    conn.client_mut().resync(&s);
    let c = conn.client_mut();
    c.start_path(
        FeedMmPerMin::from_f64(args.f_max).0.to_bits(),
        FeedMmPerMin::from_f64(args.f_min).0.to_bits(),
    );
    for p in &pts {
        c.point(p.pos.to_bits(), p.feed_cap.map(|f| f.0.to_bits()));
    }
    c.end_path();
    conn.flush(timeout, &mut seen)?;
    let deadline = Instant::now() + timeout;
    let last = loop {
        let s = conn.status(20, &mut seen)?;
        // Every point scheduled and reached (`point_reached` counts from 1).
        if s.motion == Motion::Idle && s.points_held == 0 && s.point_reached as usize >= pts.len() {
            break s;
        }
        if Instant::now() > deadline {
            bail!("the path did not finish within {} s", args.timeout_s);
        }
        std::thread::sleep(Duration::from_millis(200));
    };
    scheduled.sort_by_key(|r| r.0);
    println!("seq,index,feed_mm_per_min");
    for (seq, index, feed) in scheduled {
        println!("{seq},{index},{}", feed as f64 / 4294967296.0);
    }
    eprintln!("{last:?}");
    Ok(())
}
