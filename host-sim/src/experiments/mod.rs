//! One folder per paper, each with the same shape: the **model** (what the
//! paper describes, on fuzzy-core's controllers and host-sim's machines),
//! the **command** (`command.rs`: the subcommand's `Args` and `run`) and the
//! **report** (the table or figures the command prints and writes).
//!
//! | paper | folder | model | command | report |
//! |---|---|---|---|---|
//! | Lin, Lin & Wang 2021 (fuzzy feedrate scheduling, Tables 10-12) | [`lin2021`] | [`lin2021::compare`] (runs, claims), methods in [`crate::methods`] | `host-sim compare` | [`lin2021::report`] |
//! | Njiri, Ikua & Nyakoe (force-feedback feed override) | [`njiri`] | [`njiri`], [`njiri::force_model`] | `host-sim njiri` | [`njiri::command`] |
//! | Nagata, Kuribayashi, Kusumoto & Watanabe (fuzzy post-processor) | [`nagata`] | [`nagata`], [`nagata::relief`] | `host-sim nagata` | [`nagata::command`] |
//! | Dat & Phuc 2024 (FANUC acc/dec, corner compensation) | [`dat_phuc2024`] | [`dat_phuc2024::fanuc`], [`dat_phuc2024::before_interpolation`], [`dat_phuc2024::corner_comp`] | `host-sim corner` | [`dat_phuc2024::corner_comp::table`] |
//! | Cho, Lee & Jeon (contour-error fuzzy feed control, X-Y servo) | [`cho`] | [`cho::servo_xy`], [`cho::feed_control`] | `host-sim cho` | [`cho::feed_control::table`] |
//!
//! The machines of Dat & Phuc and of Cho et al. are also the simulated
//! machines of every other command ([`crate::machine::MachineConfig`]).
//! Commands that belong to no paper (`simulate`, `plan`, `schedule`,
//! `controller`, …) live in [`crate::cli`], with the same `Args` + `run`
//! pattern.

pub mod cho;
pub mod dat_phuc2024;
pub mod lin2021;
pub mod nagata;
pub mod njiri;
