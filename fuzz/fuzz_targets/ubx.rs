#![no_main]
//! u-blox UBX logs: frames, RXM-RAWX, RXM-SFRBX (GPS, Galileo, BeiDou D1/D2, GLONASS; seed
//! `sfrbx_bds_glo.ubx`) and TIM-TM2 decoding; the log read as it is and with every frame's
//! checksum made right; the input also as bare RXM-SFRBX payloads.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use gnss::raw::RawFormat;
    // with every frame's checksum made right, so that a mutated frame reaches the log's items
    // (epochs, time marks in RINEX order, ephemerides evaluated)
    let right = ppkat_fuzz::checks_made_right::<gnss::raw::ubx::Ubx>(data, |f| {
        let n = f.len();
        let good = gnss::raw::ubx::frame(f[2], f[3], &f[6..n - 2]);
        f[n - 2..].copy_from_slice(&good[n - 2..]);
    });
    // the input as it is (frames with bad checksums), when that differs
    ppkat_fuzz::read_as_is_when_changed("f.ubx", data, &right, RawFormat::Ubx);
    with_file("f.ubx", &right, |p| {
        ppkat_fuzz::use_items(p, RawFormat::Ubx, None);
    });
    let _ = gnss::raw::ubx::decode_rawx(data);
    let _ = gnss::raw::ubx::decode_tm2(data);
    sfrbx_payloads(data);
});

/// The input as RXM-SFRBX payloads back to back, into one navigation decoder. A log's frames
/// carry a checksum a mutation rarely keeps right, so through the log the GPS and Galileo
/// decoders were never reached; here subframes and pages can complete an ephemeris.
fn sfrbx_payloads(data: &[u8]) {
    // GPS week 2318, 300 000 s into it, in GPST milliseconds.
    const NOW_MS: i64 = (2318 * 604_800 + 300_000) * 1000;
    let mut nav = gnss::raw::ubx_nav::NavDecoder::new();
    let mut stats = gnss::raw::RawStats::default();
    let mut rest = data;
    while rest.len() >= 8 {
        let n = (8 + 4 * rest[4] as usize).min(rest.len());
        let _ = nav.push(&rest[..n], Some(NOW_MS), &mut stats);
        rest = &rest[n..];
    }
}
