#![no_main]
//! u-blox UBX logs: frames, RXM-RAWX and TIM-TM2 decoding.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use gnss::raw::{items::for_each_item, RawFormat};
    with_file("f.ubx", data, |p| {
        let _ = for_each_item(p, Some(RawFormat::Ubx), None, |_| {});
    });
    let _ = gnss::raw::ubx::decode_rawx(data);
    let _ = gnss::raw::ubx::decode_tm2(data);
});
