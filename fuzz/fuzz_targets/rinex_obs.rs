#![no_main]
//! RINEX observation files (2, 3, 4, Hatanaka, gzip by content).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.obs", data, |p| {
        let _ = gnss::rinex::ObsFile::read(p);
    });
});
