//! The byte-level receiver: real-time bytes picked out of the stream
//! wherever they fall, the rest assembled into lines and cleaned as Grbl
//! cleans them before it executes them.
//!
//! Sources: Grbl 1.1h `grbl/serial.c` (the receive interrupt `ISR(SERIAL_RX)`:
//! which bytes are real-time commands, extended ASCII dropped),
//! `grbl/config.h` (`CMD_*` values), `grbl/protocol.c`
//! (`protocol_main_loop`: line ends, cleaning, overflow), grblHAL
//! `protocol.c` (`protocol_main_loop`: a CR LF pair is one line end;
//! `CMD_STATUS_REPORT_ALL` 0x87 in `grbl.h`).

/// Grbl's line buffer, cleaned characters plus the terminator (Grbl's
/// `LINE_BUFFER_SIZE` is 80, `protocol.h`): a cleaned line holds at most
/// `LINE_BUFFER_SIZE - 1` characters, as in Grbl. 256 here: long enough
/// for the interpreter's expressions and `$J=` lines with three axes and
/// inch values, while a sender still counts its lines against 128.
pub const LINE_BUFFER_SIZE: usize = 256;

/// Longest raw line kept in [`Line::raw`] (characters before cleaning;
/// longer ones are cut there, [`Line::raw_truncated`]). Comments do not
/// count towards Grbl's overflow, so a raw line may be longer than
/// [`LINE_BUFFER_SIZE`] and still run.
pub const RAW_LINE_MAX: usize = 1024;

/// The receive buffer the server must give each connection, in bytes,
/// and the size to report in `Bf:` and `[OPT:]`. Grbl's is 128
/// (`serial.h` `RX_BUFFER_SIZE`); the senders count unacknowledged bytes
/// against 120, 127 or 128 (cncjs, bCNC, UGS) or against `Bf:`/`[OPT:]`
/// (cncjs when idle), so any size of at least 128 works; grblHAL's default
/// is 1024 as here.
pub const RX_BUFFER_SIZE: usize = 1024;

/// A real-time command: one byte, acted on at once, never part of a line
/// (`grbl/config.h` `CMD_*`, commands.md "Realtime commands").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Realtime {
    /// `?` status report.
    StatusReport,
    /// `~` cycle start / resume.
    CycleStart,
    /// `!` feed hold.
    FeedHold,
    /// 0x18 (ctrl-x) soft reset.
    Reset,
    /// 0x84 safety door.
    SafetyDoor,
    /// 0x85 jog cancel (Grbl acts on it only in the jog state).
    JogCancel,
    /// 0x87 full status report (grblHAL `CMD_STATUS_REPORT_ALL`; not in
    /// Grbl 1.1, which drops the byte): a report with every field.
    StatusReportAll,
    /// 0x90 feed override to 100 %.
    FeedOvrReset,
    /// 0x91 feed override +10 %.
    FeedOvrCoarsePlus,
    /// 0x92 feed override −10 %.
    FeedOvrCoarseMinus,
    /// 0x93 feed override +1 %.
    FeedOvrFinePlus,
    /// 0x94 feed override −1 %.
    FeedOvrFineMinus,
    /// 0x95 rapid override to 100 %.
    RapidOvrReset,
    /// 0x96 rapid override to 50 %.
    RapidOvrMedium,
    /// 0x97 rapid override to 25 %.
    RapidOvrLow,
    /// 0x99 spindle override to 100 %.
    SpindleOvrReset,
    /// 0x9A spindle override +10 %.
    SpindleOvrCoarsePlus,
    /// 0x9B spindle override −10 %.
    SpindleOvrCoarseMinus,
    /// 0x9C spindle override +1 %.
    SpindleOvrFinePlus,
    /// 0x9D spindle override −1 %.
    SpindleOvrFineMinus,
    /// 0x9E spindle stop toggle (in a hold only).
    SpindleStop,
    /// 0xA0 flood coolant toggle.
    FloodToggle,
    /// 0xA1 mist coolant toggle.
    MistToggle,
}

/// Every [`Realtime`] command.
pub const REALTIME: [Realtime; 23] = {
    use Realtime::*;
    [
        StatusReport,
        CycleStart,
        FeedHold,
        Reset,
        SafetyDoor,
        JogCancel,
        StatusReportAll,
        FeedOvrReset,
        FeedOvrCoarsePlus,
        FeedOvrCoarseMinus,
        FeedOvrFinePlus,
        FeedOvrFineMinus,
        RapidOvrReset,
        RapidOvrMedium,
        RapidOvrLow,
        SpindleOvrReset,
        SpindleOvrCoarsePlus,
        SpindleOvrCoarseMinus,
        SpindleOvrFinePlus,
        SpindleOvrFineMinus,
        SpindleStop,
        FloodToggle,
        MistToggle,
    ]
};

impl Realtime {
    /// The command of a byte, if it is one. 0x80-0x83 (Grbl's commented-out
    /// alternates), 0x86 (debug builds) and 0x98 (`CMD_RAPID_OVR_EXTRA_LOW`,
    /// "not supported") are not.
    pub const fn from_byte(b: u8) -> Option<Realtime> {
        use Realtime::*;
        Some(match b {
            b'?' => StatusReport,
            b'~' => CycleStart,
            b'!' => FeedHold,
            0x18 => Reset,
            0x84 => SafetyDoor,
            0x85 => JogCancel,
            0x87 => StatusReportAll,
            0x90 => FeedOvrReset,
            0x91 => FeedOvrCoarsePlus,
            0x92 => FeedOvrCoarseMinus,
            0x93 => FeedOvrFinePlus,
            0x94 => FeedOvrFineMinus,
            0x95 => RapidOvrReset,
            0x96 => RapidOvrMedium,
            0x97 => RapidOvrLow,
            0x99 => SpindleOvrReset,
            0x9A => SpindleOvrCoarsePlus,
            0x9B => SpindleOvrCoarseMinus,
            0x9C => SpindleOvrFinePlus,
            0x9D => SpindleOvrFineMinus,
            0x9E => SpindleStop,
            0xA0 => FloodToggle,
            0xA1 => MistToggle,
            _ => return None,
        })
    }

    /// Its byte.
    pub const fn byte(self) -> u8 {
        use Realtime::*;
        match self {
            StatusReport => b'?',
            CycleStart => b'~',
            FeedHold => b'!',
            Reset => 0x18,
            SafetyDoor => 0x84,
            JogCancel => 0x85,
            StatusReportAll => 0x87,
            FeedOvrReset => 0x90,
            FeedOvrCoarsePlus => 0x91,
            FeedOvrCoarseMinus => 0x92,
            FeedOvrFinePlus => 0x93,
            FeedOvrFineMinus => 0x94,
            RapidOvrReset => 0x95,
            RapidOvrMedium => 0x96,
            RapidOvrLow => 0x97,
            SpindleOvrReset => 0x99,
            SpindleOvrCoarsePlus => 0x9A,
            SpindleOvrCoarseMinus => 0x9B,
            SpindleOvrFinePlus => 0x9C,
            SpindleOvrFineMinus => 0x9D,
            SpindleStop => 0x9E,
            FloodToggle => 0xA0,
            MistToggle => 0xA1,
        }
    }
}

/// A received line.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Line {
    /// The line as Grbl executes it: spaces, control characters, `/` and
    /// comments removed, letters upper-cased. Empty for a blank or
    /// comment-only line (answered `ok`).
    pub text: String,
    /// The line as received, without its line end and the real-time bytes
    /// (bytes that are not ASCII shown as U+FFFD where they do not form
    /// UTF-8); for logs and echo.
    pub raw: String,
    /// The cleaned line did not fit [`LINE_BUFFER_SIZE`]: answer
    /// `error:11` and do not execute it (`protocol_main_loop`,
    /// `STATUS_OVERFLOW`). [`Line::text`] holds what fitted.
    pub overflow: bool,
    /// [`Line::raw`] was cut at [`RAW_LINE_MAX`].
    pub raw_truncated: bool,
}

/// What the receiver found in the bytes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Event {
    /// A real-time command, in its place in the stream.
    Realtime(Realtime),
    /// A line, at its line end.
    Line(Line),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Comment {
    None,
    /// `(`: until `)` or the line end.
    Paren,
    /// `;`: until the line end.
    Semicolon,
}

/// The receiver of one connection: bytes in ([`Receiver::push`],
/// [`Receiver::feed`]), [`Event`]s out. No I/O, no clock; a line split
/// over any number of reads comes out whole.
///
/// Rules, each Grbl's unless said:
/// - real-time bytes ([`Realtime::from_byte`]) are taken out wherever
///   they are, mid-line included, and never reach the line (`serial.c`);
/// - other bytes ≥ 0x80 are dropped (`serial.c`: "Throw away any unfound
///   extended-ASCII character"), but see UTF-8 below;
/// - CR and LF each end a line (`protocol_main_loop`); a CR LF or LF CR
///   pair ends one line, as in grblHAL (`protocol_main_loop`: "do not
///   process as empty line if part of crlf"). Grbl 1.1 would answer the
///   empty line between the two with a second `ok`, which a
///   character-counting sender would take for the next line's;
/// - cleaning (`protocol_main_loop`): bytes ≤ 0x20 (space and control
///   characters) and `/` (block delete, not supported) are dropped; `(`
///   starts a comment that `)` ends, `;` one that the line end ends
///   (nesting is not tracked: `(a(b)c)` leaves `C)`, as in Grbl);
///   `a`-`z` are upper-cased; everything else, DEL (0x7F) and `%`
///   included, is kept;
/// - a cleaned line longer than `LINE_BUFFER_SIZE - 1` sets
///   [`Line::overflow`]; the rest of it is dropped up to the line end;
/// - 0x18 (soft reset) also drops the partial line, as the reset does in
///   Grbl (`main.c` restarts `protocol_main_loop` and empties the serial
///   buffer; grblHAL clears the line on `ASCII_CAN`). Bytes after it are
///   a new line. Emptying what the server has buffered but not yet fed is
///   the server's choice.
///
/// UTF-8 (ours, [`Receiver::new`]): the continuation bytes of a UTF-8
/// character (a lead byte 0xC2-0xF4 and the 0x80-0xBF bytes it announces)
/// are dropped as text, not taken as real-time commands. Grbl acts on
/// them: an em dash (E2 80 94) in a comment is a feed override −1 %, "Ą"
/// (C4 84) a safety door. Senders write a line in one piece, so a real
/// command never falls inside a character. [`Receiver::grbl_strict`] acts
/// on them as Grbl does. A real-time byte 0x80-0x9F written as a
/// character, C2 and the byte (U+0080-U+009F, C1 controls, never text), is
/// the command: cncjs and bCNC write them as strings, UTF-8 encoded, and
/// Grbl acts on them by dropping the C2.
#[derive(Clone, Debug)]
pub struct Receiver {
    text: String,
    raw: Vec<u8>,
    overflow: bool,
    raw_truncated: bool,
    comment: Comment,
    /// The line end that ended the last line, while nothing has followed it.
    last_eol: Option<u8>,
    /// Continuation bytes still expected of a UTF-8 character.
    utf8_left: u8,
    /// Its lead byte.
    utf8_lead: u8,
    utf8: bool,
}

impl Default for Receiver {
    fn default() -> Self {
        Receiver::new()
    }
}

impl Receiver {
    /// A receiver that keeps UTF-8 characters whole (see the type's
    /// documentation).
    pub fn new() -> Receiver {
        Receiver {
            text: String::new(),
            raw: Vec::new(),
            overflow: false,
            raw_truncated: false,
            comment: Comment::None,
            last_eol: None,
            utf8_left: 0,
            utf8_lead: 0,
            utf8: true,
        }
    }

    /// A receiver that acts on every real-time byte, inside UTF-8
    /// characters too, as Grbl does.
    pub fn grbl_strict() -> Receiver {
        Receiver {
            utf8: false,
            ..Receiver::new()
        }
    }

    /// Bytes of the current, unfinished line held (raw, as received).
    pub fn pending(&self) -> usize {
        self.raw.len()
    }

    /// Drop the unfinished line.
    pub fn clear(&mut self) {
        self.text.clear();
        self.raw.clear();
        self.overflow = false;
        self.raw_truncated = false;
        self.comment = Comment::None;
        self.last_eol = None;
        self.utf8_left = 0;
    }

    /// The events of some bytes, in stream order.
    pub fn feed<'a>(&'a mut self, bytes: &'a [u8]) -> impl Iterator<Item = Event> + 'a {
        bytes.iter().filter_map(move |&b| self.push(b))
    }

    /// One byte: a real-time command, a finished line, or nothing yet.
    pub fn push(&mut self, b: u8) -> Option<Event> {
        if self.utf8 {
            if self.utf8_left > 0 && self.utf8_lead == 0xC2 && b <= 0x9F {
                if let Some(rt) = Realtime::from_byte(b) {
                    self.utf8_left = 0;
                    if self.raw.last() == Some(&0xC2) {
                        self.raw.pop();
                    }
                    return Some(Event::Realtime(rt));
                }
            }
            if self.utf8_left > 0 && (0x80..=0xBF).contains(&b) {
                self.utf8_left -= 1;
                self.keep_raw(b);
                return None;
            }
            self.utf8_left = 0;
        }
        if let Some(rt) = Realtime::from_byte(b) {
            if rt == Realtime::Reset {
                self.clear();
            }
            return Some(Event::Realtime(rt));
        }
        if b >= 0x80 {
            if self.utf8 {
                self.utf8_lead = b;
                self.utf8_left = match b {
                    0xC2..=0xDF => 1,
                    0xE0..=0xEF => 2,
                    0xF0..=0xF4 => 3,
                    _ => 0,
                };
                if self.utf8_left > 0 {
                    self.keep_raw(b);
                }
            }
            return None;
        }
        if b == b'\n' || b == b'\r' {
            if let Some(prev) = self.last_eol.take() {
                if prev != b && self.raw.is_empty() {
                    return None;
                }
            }
            let line = self.finish();
            self.last_eol = Some(b);
            return Some(Event::Line(line));
        }
        self.last_eol = None;
        self.keep_raw(b);
        self.clean(b);
        None
    }

    fn keep_raw(&mut self, b: u8) {
        if self.raw.len() < RAW_LINE_MAX {
            self.raw.push(b);
        } else {
            self.raw_truncated = true;
        }
    }

    /// `protocol_main_loop`'s filter for one byte below 0x80 that is not a
    /// line end.
    fn clean(&mut self, b: u8) {
        if self.overflow || self.comment != Comment::None {
            if b == b')' && self.comment == Comment::Paren {
                self.comment = Comment::None;
            }
            return;
        }
        match b {
            0..=b' ' | b'/' => {}
            b'(' => self.comment = Comment::Paren,
            b';' => self.comment = Comment::Semicolon,
            _ if self.text.len() >= LINE_BUFFER_SIZE - 1 => self.overflow = true,
            _ => self.text.push(char::from(b.to_ascii_uppercase())),
        }
    }

    fn finish(&mut self) -> Line {
        let line = Line {
            text: core::mem::take(&mut self.text),
            raw: String::from_utf8_lossy(&self.raw).into_owned(),
            overflow: self.overflow,
            raw_truncated: self.raw_truncated,
        };
        self.clear();
        line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn events(r: &mut Receiver, bytes: &[u8]) -> Vec<Event> {
        r.feed(bytes).collect()
    }

    fn lines(bytes: &[u8]) -> Vec<String> {
        let mut r = Receiver::new();
        events(&mut r, bytes)
            .into_iter()
            .filter_map(|e| match e {
                Event::Line(l) => Some(l.text),
                Event::Realtime(_) => None,
            })
            .collect()
    }

    fn line(text: &str) -> Event {
        Event::Line(Line {
            text: text.to_string(),
            raw: String::new(),
            overflow: false,
            raw_truncated: false,
        })
    }

    /// Events with `raw` blanked, to compare texts and commands.
    fn shape(ev: Vec<Event>) -> Vec<Event> {
        ev.into_iter()
            .map(|e| match e {
                Event::Line(l) => line(&l.text),
                e => e,
            })
            .collect()
    }

    #[test]
    fn realtime_bytes_round_trip() {
        for rt in REALTIME {
            assert_eq!(Realtime::from_byte(rt.byte()), Some(rt));
        }
        let n = (0..=255u8)
            .filter(|&b| Realtime::from_byte(b).is_some())
            .count();
        assert_eq!(n, REALTIME.len());
        for b in [0x80, 0x81, 0x82, 0x83, 0x86, 0x98, 0x9F, 0xA2, 0xFF] {
            assert_eq!(Realtime::from_byte(b), None);
        }
    }

    #[test]
    fn every_realtime_byte_mid_line() {
        for rt in REALTIME {
            let mut r = Receiver::grbl_strict();
            let mut bytes = b"G1 X1".to_vec();
            bytes.push(rt.byte());
            bytes.extend_from_slice(b"0 F100\n");
            let ev = shape(events(&mut r, &bytes));
            if rt == Realtime::Reset {
                // The reset drops the line so far.
                assert_eq!(ev, vec![Event::Realtime(rt), line("0F100")]);
            } else {
                assert_eq!(ev, vec![Event::Realtime(rt), line("G1X10F100")], "{rt:?}");
            }
            // The same with the UTF-8-aware receiver.
            let mut r = Receiver::new();
            assert_eq!(shape(events(&mut r, &bytes)), ev, "{rt:?}");
        }
    }

    #[test]
    fn realtime_in_a_comment_and_between_cr_and_lf() {
        let mut r = Receiver::new();
        let ev = shape(events(&mut r, b"G0 (wait?)X1\r!\n"));
        assert_eq!(
            ev,
            vec![
                Event::Realtime(Realtime::StatusReport),
                line("G0X1"),
                Event::Realtime(Realtime::FeedHold),
            ]
        );
    }

    #[test]
    fn line_split_across_reads() {
        let mut r = Receiver::new();
        let input = b"g1 x1.5 y-2 ; move\r\n$J=G91X1F100\n";
        let mut got = Vec::new();
        for chunk in input.chunks(1) {
            got.extend(events(&mut r, chunk));
        }
        let mut whole = Receiver::new();
        assert_eq!(got, events(&mut whole, input));
        assert_eq!(shape(got), vec![line("G1X1.5Y-2"), line("$J=G91X1F100")]);
        for split in 0..input.len() {
            let mut r = Receiver::new();
            let mut got = events(&mut r, &input[..split]);
            got.extend(events(&mut r, &input[split..]));
            assert_eq!(shape(got.clone()).len(), 2, "split at {split}");
        }
        assert_eq!(r.pending(), 0);
        let _ = events(&mut r, b"G0 X");
        assert_eq!(r.pending(), 4);
    }

    #[test]
    fn line_ends() {
        assert_eq!(lines(b"A\nB\n"), ["A", "B"]);
        assert_eq!(lines(b"A\rB\r"), ["A", "B"]);
        assert_eq!(lines(b"A\r\nB\r\n"), ["A", "B"]);
        assert_eq!(lines(b"A\n\rB\n\r"), ["A", "B"]);
        // Blank lines are lines (answered ok for syncing).
        assert_eq!(lines(b"\n\n"), ["", ""]);
        assert_eq!(lines(b"A\r\n\r\n"), ["A", ""]);
        assert_eq!(lines(b"A\n\n"), ["A", ""]);
        assert_eq!(lines(b"A\r\rB"), ["A", ""]);
        // A CR LF pair split across reads.
        let mut r = Receiver::new();
        assert_eq!(shape(events(&mut r, b"A\r")), vec![line("A")]);
        assert_eq!(events(&mut r, b"\n"), vec![]);
        // No line end yet: nothing.
        assert!(lines(b"G0 X1").is_empty());
    }

    #[test]
    fn cleaning_as_grbl() {
        assert_eq!(lines(b"g0 x1 (comment) y2\n"), ["G0X1Y2"]);
        assert_eq!(lines(b"(a(b)c)\n"), ["C)"]);
        assert_eq!(lines(b"; whole line\n"), [""]);
        assert_eq!(lines(b"G1 X1 ; (unclosed\nG2\n"), ["G1X1", "G2"]);
        assert_eq!(lines(b"(unclosed\nG2\n"), ["", "G2"]);
        assert_eq!(lines(b"/G0 X1\n"), ["G0X1"]);
        assert_eq!(lines(b"\tG0\x01X1\x7f\n"), ["G0X1\x7f"]);
        assert_eq!(lines(b"%\n"), ["%"]);
        assert_eq!(lines(b"$j=g91 x1 f100\n"), ["$J=G91X1F100"]);
        let mut r = Receiver::new();
        match events(&mut r, b"  G0  x1 (note)\n").pop() {
            Some(Event::Line(l)) => assert_eq!(l.raw, "  G0  x1 (note)"),
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn bytes_above_0x7f_dropped() {
        let mut strict = Receiver::grbl_strict();
        let ev = shape(events(&mut strict, b"G0\x80\xFFX1\n"));
        assert_eq!(ev, vec![line("G0X1")]);
        // Grbl acts on the bytes of an em dash (E2 80 94): 0x94 is a
        // feed override.
        let comment = "G0 (6mm \u{2014} Ą) X1\n".as_bytes();
        let ev = shape(events(&mut strict, comment));
        assert_eq!(
            ev,
            vec![
                Event::Realtime(Realtime::FeedOvrFineMinus),
                Event::Realtime(Realtime::SafetyDoor),
                line("G0X1")
            ]
        );
        // Ours keeps UTF-8 characters whole, and in the raw line.
        let mut r = Receiver::new();
        let ev = events(&mut r, comment);
        assert_eq!(ev.len(), 1);
        match &ev[0] {
            Event::Line(l) => {
                assert_eq!(l.text, "G0X1");
                assert_eq!(l.raw, "G0 (6mm \u{2014} Ą) X1");
            }
            e => panic!("{e:?}"),
        }
        // A lone lead byte does not swallow more than its character.
        let ev = shape(events(&mut r, b"\xC3?\x85\n"));
        assert_eq!(
            ev,
            vec![
                Event::Realtime(Realtime::StatusReport),
                Event::Realtime(Realtime::JogCancel),
                line("")
            ]
        );
        let ev = shape(events(&mut r, b"\xE2\x80\x85\x85\n"));
        assert_eq!(ev, vec![Event::Realtime(Realtime::JogCancel), line("")]);
        // A real-time byte written as a character (U+0085, U+0091) is the
        // command; a Latin-1 letter or NBSP (C2 A0) stays text.
        let ev = shape(events(&mut r, "\u{85}G0 (\u{a0}°)\u{91}X1\n".as_bytes()));
        assert_eq!(
            ev,
            vec![
                Event::Realtime(Realtime::JogCancel),
                Event::Realtime(Realtime::FeedOvrCoarsePlus),
                line("G0X1")
            ]
        );
    }

    #[test]
    fn overflow() {
        let max = LINE_BUFFER_SIZE - 1;
        let mut r = Receiver::new();
        let fits = vec![b'X'; max];
        match events(&mut r, &[fits.as_slice(), b"\n"].concat()).pop() {
            Some(Event::Line(l)) => assert!(!l.overflow && l.text.len() == max),
            e => panic!("{e:?}"),
        }
        let long = vec![b'X'; max + 1];
        match events(&mut r, &[long.as_slice(), b"\n"].concat()).pop() {
            Some(Event::Line(l)) => assert!(l.overflow && l.text.len() == max),
            e => panic!("{e:?}"),
        }
        // The next line is clean again.
        assert_eq!(shape(events(&mut r, b"G0\n")), vec![line("G0")]);
        // Spaces and comments do not count.
        let spaced: Vec<u8> = fits.iter().flat_map(|&b| [b' ', b]).collect();
        match events(&mut r, &[spaced.as_slice(), b"(comment)\n"].concat()).pop() {
            Some(Event::Line(l)) => assert!(!l.overflow),
            e => panic!("{e:?}"),
        }
        // A huge raw line is cut, and the real-time bytes still come out.
        let mut huge = vec![b' '; 10 * RAW_LINE_MAX];
        huge.push(b'?');
        huge.push(b'\n');
        let ev = events(&mut r, &huge);
        assert_eq!(ev[0], Event::Realtime(Realtime::StatusReport));
        match &ev[1] {
            Event::Line(l) => {
                assert!(l.raw_truncated && !l.overflow && l.text.is_empty());
                assert_eq!(l.raw.len(), RAW_LINE_MAX);
            }
            e => panic!("{e:?}"),
        }
    }

    #[test]
    fn reset_drops_the_partial_line() {
        let mut r = Receiver::new();
        let ev = shape(events(&mut r, b"G0 X1\x18G1\n"));
        assert_eq!(ev, vec![Event::Realtime(Realtime::Reset), line("G1")]);
        assert_eq!(r.pending(), 0);
    }

    #[test]
    fn no_panic_on_any_bytes() {
        let mut r = Receiver::new();
        let mut s = Receiver::grbl_strict();
        let mut x: u32 = 0x1234_5678;
        for _ in 0..200_000 {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            let b = (x >> 24) as u8;
            for e in r.feed(&[b]).chain(s.feed(&[b])) {
                if let Event::Line(l) = e {
                    assert!(l.text.len() < LINE_BUFFER_SIZE);
                    assert!(l.text.bytes().all(|c| c > b' ' && c < 0x80));
                }
            }
        }
    }
}
