#![no_main]
//! .pos trajectories (ours and RTKLIB's).

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    with_file("f.pos", data, |p| {
        let _ = gnss::trajectory::Trajectory::read_pos(p);
    });
});
