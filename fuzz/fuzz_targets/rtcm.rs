#![no_main]
//! RTCM 3 logs: frames, MSM observations, ephemerides (1019, 1020, 1042, 1044, 1045, 1046),
//! station messages (1005–1008, 1033) and the week's resolution with and without a hint.
//! A mutation rarely keeps a frame's CRC-24Q right, so through the log the items of frames
//! the seeds did not hold were never reached: the log is read a second time with each frame's
//! CRC recomputed.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use gnss::raw::{items::for_each_item, RawFormat, TimeHint};
    // with every frame's CRC made right, so that a mutated payload reaches the log's items
    // (the week's resolution, the station, GLONASS channels, ephemerides evaluated)
    let right = ppkat_fuzz::checks_made_right::<gnss::raw::rtcm::Rtcm3>(data, |f| {
        let n = f.len();
        let good = gnss::raw::rtcm::frame(&f[3..n - 3]);
        f[n - 3..].copy_from_slice(&good[n - 3..]);
    });
    // the input as it is (frames with bad CRCs, and what lies between frames), when that
    // differs: an input whose CRCs were all right is read below
    ppkat_fuzz::read_as_is_when_changed("f.rtcm3", data, &right, RawFormat::Rtcm3);
    with_file("f.rtcm3", &right, |p| {
        for hint in [
            None,
            Some(TimeHint::Year(2024)),
            Some(TimeHint::Date(2024, 3, 5)),
        ] {
            let _ = for_each_item(p, Some(RawFormat::Rtcm3), hint, |_| {});
        }
        ppkat_fuzz::use_items(p, RawFormat::Rtcm3, Some(TimeHint::Year(2024)));
    });
    // a payload on its own, as every decoder sees it
    let _ = gnss::raw::rtcm_msm::decode_msm(data);
    let now = Some(2303 * gnss::raw::rtcm_msm::WEEK_MS);
    if let Ok(r) = gnss::raw::rtcm_eph::decode_ephemeris(data, now, None) {
        let _ = gnss::raw::rtcm_eph_write::ephemeris_frame(&r);
    }
    let mut st = gnss::raw::rtcm_station::Station::default();
    let _ = st.add(data);
    let _ = st.rinex();
});
