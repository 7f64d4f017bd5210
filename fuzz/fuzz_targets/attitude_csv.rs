#![no_main]
//! Attitude CSV, read and sampled.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use integration::exposure::attitude::{AngleConvention, AttitudeTable};
    with_file("f.csv", data, |p| {
        if let Ok(t) = AttitudeTable::read_csv(p, AngleConvention::YawPitchRoll) {
            for k in 0..t.times.len().min(8) {
                let _ = t.at(t.times[k] + hifitime::Duration::from_seconds(0.05));
            }
        }
    });
});
