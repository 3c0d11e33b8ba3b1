//! A record of a run (`--record FILE`), one JSON object a line: the path
//! as sent (settings, every point with its sequence number and bits), the
//! immediate messages sent, and every message from the controller, each
//! with the time since streaming started. For diagnosis, and for tests
//! that replay the controller's motion on the host from what it reported.
//!
//! ```text
//! {"t_s":0.0,"path":{"start_seq":0,"f_max_bits":…,"f_min_bits":…,"points":2001}}
//! {"t_s":0.0,"point":{"seq":1,"pos_bits":[0,0,0],"cap_bits":null,"line":0}}
//! {"t_s":0.8,"tx":"Hold"}
//! {"t_s":0.8,"rx":{"Status":{…}}}
//! ```
//! (`tx` and `rx` are `link::HostMsg` and `link::DeviceMsg` in serde's
//! JSON form.)

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use link::{DeviceMsg, HostMsg};
use serde_json::json;

/// Where records go (nowhere unless a file was given).
pub struct Recorder {
    out: Option<BufWriter<File>>,
    error: Option<io::Error>,
}

impl Recorder {
    /// Records to nowhere.
    pub fn none() -> Self {
        Recorder {
            out: None,
            error: None,
        }
    }

    /// Records to a new file.
    pub fn create(path: &Path) -> io::Result<Self> {
        Ok(Recorder {
            out: Some(BufWriter::new(File::create(path)?)),
            error: None,
        })
    }

    fn write(&mut self, v: serde_json::Value) {
        if let Some(o) = self.out.as_mut() {
            if let Err(e) = serde_json::to_writer(&mut *o, &v)
                .map_err(io::Error::other)
                .and_then(|_| o.write_all(b"\n"))
            {
                self.error.get_or_insert(e);
            }
        }
    }

    /// The path's settings and size.
    pub fn path(&mut self, t_s: f64, start_seq: u32, f_max_bits: i64, f_min_bits: i64, n: usize) {
        if self.out.is_some() {
            self.write(json!({"t_s": t_s, "path": {"start_seq": start_seq, "f_max_bits": f_max_bits, "f_min_bits": f_min_bits, "points": n}}));
        }
    }

    /// A point as queued.
    pub fn point(&mut self, seq: u32, pos_bits: [i64; 3], cap_bits: Option<i64>, line: u32) {
        if self.out.is_some() {
            self.write(json!({"t_s": 0.0, "point": {"seq": seq, "pos_bits": pos_bits, "cap_bits": cap_bits, "line": line}}));
        }
    }

    /// A machine command of the path (sequence number, what, source line).
    pub fn machine(&mut self, seq: u32, cmd: &link::MachineCmd, line: u32) {
        if self.out.is_some() {
            self.write(json!({"t_s": 0.0, "machine": {"seq": seq, "cmd": cmd, "line": line}}));
        }
    }

    /// An immediate message sent.
    pub fn sent(&mut self, t_s: f64, m: &HostMsg) {
        if self.out.is_some() {
            self.write(json!({"t_s": t_s, "tx": m}));
        }
    }

    /// A message from the controller.
    pub fn received(&mut self, t_s: f64, m: &DeviceMsg) {
        if self.out.is_some() {
            self.write(json!({"t_s": t_s, "rx": m}));
        }
    }

    /// Flush; the first error since the start, if any.
    pub fn finish(&mut self) -> io::Result<()> {
        if let Some(o) = self.out.as_mut() {
            if let Err(e) = o.flush() {
                self.error.get_or_insert(e);
            }
        }
        match self.error.take() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use link::Status;

    #[test]
    fn records_round_trip_as_json_lines() {
        let path = std::env::temp_dir().join(format!("sender-rec-{}.jsonl", std::process::id()));
        let mut r = Recorder::create(&path).unwrap();
        r.path(0.0, 5, 3000 << 32, 60 << 32, 2);
        r.point(6, [1, 2, 3], Some(400 << 32), 12);
        r.sent(0.5, &HostMsg::Override { percent: 50 });
        let st = DeviceMsg::Status(Status {
            next_seq: 9,
            ..Status::default()
        });
        r.received(0.6, &st);
        r.finish().unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<serde_json::Value> = text
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect();
        assert_eq!(lines.len(), 4);
        assert_eq!(lines[0]["path"]["start_seq"], 5);
        assert_eq!(lines[1]["point"]["line"], 12);
        let tx: HostMsg = serde_json::from_value(lines[2]["tx"].clone()).unwrap();
        assert_eq!(tx, HostMsg::Override { percent: 50 });
        let rx: DeviceMsg = serde_json::from_value(lines[3]["rx"].clone()).unwrap();
        assert_eq!(rx, st);
        let _ = std::fs::remove_file(&path);
    }
}
