#![no_main]
//! Septentrio SBF logs: blocks, MeasEpoch (Type-1/Type-2 sub-blocks), the navigation blocks
//! (GPSNav, GALNav, BDSNav, GLONav, each decoded record written back), GPSIon/GPSUtc and
//! ExtEvent; the log read as it is and with every block's CRC made right.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::with_file;

fuzz_target!(|data: &[u8]| {
    use gnss::raw::{sbf, sbf_nav, RawFormat};
    // with every block's CRC made right, so that a mutated block reaches the log's items
    // (epochs, events in RINEX order, ephemerides evaluated)
    let right = ppkat_fuzz::checks_made_right::<sbf::Sbf>(data, |b| {
        let c = sbf::crc16(&b[4..]).to_le_bytes();
        b[2..4].copy_from_slice(&c);
    });
    // the input as it is (blocks with bad CRCs), when that differs
    ppkat_fuzz::read_as_is_when_changed("f.sbf", data, &right, RawFormat::Sbf);
    with_file("f.sbf", &right, |p| {
        ppkat_fuzz::use_items(p, RawFormat::Sbf, None);
    });
    // a block on its own, as every decoder sees it
    if let Some(m) = gnss::raw::sbf_meas::decode_meas_epoch(data) {
        let mut st = gnss::raw::RawStats::default();
        let _ = gnss::raw::sbf_obs::SbfConverter::new().epoch(&m, &mut st);
    }
    if let Some(e) = sbf::decode_ext_event(data) {
        let _ = e.time();
    }
    for n in [sbf::GPS_NAV, sbf::GAL_NAV, sbf::BDS_NAV, sbf::GLO_NAV] {
        if let Ok(r) = sbf_nav::decode_nav(n, data) {
            let _ = gnss::raw::sbf_eph_write::nav_block(&r);
        }
    }
    let _ = gnss::raw::sbf_items::decode_gps_ion(data);
    let _ = gnss::raw::sbf_items::decode_gps_utc(data);
});
