//! Stream a path to a running firmware over TCP (the firmware's `cargo run`
//! puts QEMU's USART1 on `tcp::7878`) and print the feeds it schedules.
//!
//! ```text
//! cargo run -p system-tests --bin stream -- PATH.csv [--addr 127.0.0.1:7878] [--f-max 3000] [--f-min 60]
//! ```
//!
//! Output: CSV `seq,index,feed_mm_per_min`, then the final status on stderr.

use std::net::TcpStream;
use std::path::PathBuf;
use std::time::Duration;

use fuzzy_core::scheduler::SchedulerConfig;
use fuzzy_core::units::FeedMmPerMin;
use link::Motion;
use system_tests::firmware::{read_points, Firmware};

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut path, mut addr, mut f_max, mut f_min) =
        (None, "127.0.0.1:7878".to_string(), 3000.0, 60.0);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--addr" => addr = args.next().expect("--addr HOST:PORT"),
            "--f-max" => {
                f_max = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("--f-max MM_PER_MIN")
            }
            "--f-min" => {
                f_min = args
                    .next()
                    .and_then(|v| v.parse().ok())
                    .expect("--f-min MM_PER_MIN")
            }
            _ => path = Some(PathBuf::from(a)),
        }
    }
    let Some(path) = path else {
        eprintln!("usage: stream PATH.csv [--addr 127.0.0.1:7878] [--f-max 3000] [--f-min 60]");
        std::process::exit(2);
    };
    let pts = read_points(&path);
    let stream = TcpStream::connect(&addr).unwrap_or_else(|e| panic!("connect {addr}: {e}"));
    let reader = stream.try_clone().expect("socket");
    let mut fw = Firmware::over(Box::new(stream), Box::new(reader), None, PathBuf::from("-"));
    // The hello went out at reset; the status tells us where the sequence is.
    let s = fw.status();
    fw.acked = s.next_seq;
    fw.window_end = s.window_end;
    for _ in 0..s.next_seq {
        fw.queue_path_cmd(|seq| link::HostMsg::EndPath { seq });
    }
    fw.send_next = s.next_seq;
    let config = SchedulerConfig::new(FeedMmPerMin::from_f64(f_max), FeedMmPerMin::from_f64(f_min));
    fw.start_path(&config);
    fw.points(&pts);
    fw.end_path();
    fw.flush(Duration::from_secs(3600));
    let end = fw.poll_until(Duration::from_millis(200), Duration::from_secs(3600), |s| {
        s.motion == Motion::Idle && fw_done(s, pts.len())
    });
    println!("seq,index,feed_mm_per_min");
    for r in fw.scheduled_in_order() {
        println!(
            "{},{},{}",
            r.seq,
            r.index,
            r.feed_bits as f64 / 4294967296.0
        );
    }
    eprintln!("{:?}", end.last());
}

/// Every point scheduled and reached by the planner (`point_reached`
/// counts the path's points from 1).
fn fw_done(s: &link::Status, points: usize) -> bool {
    s.points_held == 0 && s.point_reached as usize >= points
}
