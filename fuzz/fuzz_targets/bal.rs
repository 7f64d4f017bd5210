#![no_main]
//! BAL problems.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.bal", data, |p| {
        let _ = photo::bal::BalProblem::read(p);
    });
});
