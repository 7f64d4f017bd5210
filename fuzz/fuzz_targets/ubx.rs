#![no_main]
//! u-blox UBX logs: frames, RXM-RAWX, RXM-SFRBX (GPS, Galileo, BeiDou D1/D2, GLONASS; seed
//! `sfrbx_bds_glo.ubx`) and TIM-TM2 decoding.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use gnss::raw::RawFormat;
    with_file("f.ubx", data, |p| {
        ppkat_fuzz::use_items(p, RawFormat::Ubx, None);
    });
    let _ = gnss::raw::ubx::decode_rawx(data);
    let _ = gnss::raw::ubx::decode_tm2(data);
});
