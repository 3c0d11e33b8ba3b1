//! The build-time settings (`src/settings.rs`) are read with `option_env!`:
//! rebuild when one changes.
fn main() {
    for var in [
        "FW_TICK_HZ",
        "FW_STEPS_PER_MM",
        "FW_FEED_MAX_MM_PER_MIN",
        "FW_AXIS_SPEED_MM_PER_MIN",
        "FW_AXIS_ACCEL_MM_PER_S2",
        "FW_JERK_MM_PER_S3",
        "FW_CHORD_NM",
        "FW_TANGENTIAL_SHARE_PERCENT",
        "FW_LINK_BAUD",
    ] {
        println!("cargo:rerun-if-env-changed={var}");
    }
}
