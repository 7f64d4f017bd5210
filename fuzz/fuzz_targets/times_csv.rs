#![no_main]
//! CSV of exposure times, GPST and UTC.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use integration::exposure::events::{read_times_csv, TimeSystem};
    with_file("f.csv", data, |p| {
        let _ = read_times_csv(p, TimeSystem::Gpst);
        let _ = read_times_csv(p, TimeSystem::Utc);
    });
});
