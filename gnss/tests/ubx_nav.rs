//! Ephemerides decoded from u-blox RXM-SFRBX (GPS LNAV, Galileo I/NAV) against the RINEX
//! navigation file RTKLIB convbin made of the same log: satellite positions and clocks from
//! the same issue of data agree to well under 1 cm; the navigation file we write reads back
//! with our reader and with the `rinex` crate.

mod common;

use gnss::orbit::{Eph, Ephemerides};
use gnss::raw::convert::{convert, Outputs};
use gnss::rinex::nav::NavFile;
use gnss::sv::Constellation;
use hifitime::Duration;
use testkit::scratch_path as tmp;

fn iode(e: &Eph) -> f64 {
    match e {
        Eph::Kepler(k) => k.iode,
        Eph::Glonass(_) => -1.0,
    }
}

#[test]
fn sfrbx_ephemerides_match_convbin_nav() {
    let Some(dir) = common::data("gnss/ubx-navsol-2025") else {
        return;
    };
    let (obs, nav) = (tmp("cold.obs"), tmp("cold.nav"));
    let outs = Outputs {
        obs: &obs,
        nav: Some(&nav),
        events: None,
        nmea: None,
    };
    let st = convert(
        &dir.join("16dBatt_no_interference_coldstart.ubx"),
        None,
        None,
        outs,
    )
    .unwrap();
    let n = &st.nav;
    eprintln!("{st}");
    // Counted independently of the decoder: every checksummed RXM-SFRBX frame (3,843).
    let src = std::fs::read(dir.join("16dBatt_no_interference_coldstart.ubx")).unwrap();
    assert_eq!(n.messages, sfrbx_frames(&src), "every SFRBX of the log");
    assert_eq!(
        (n.parity_failures, n.crc_failures, n.page_errors),
        (0, 0, 0)
    );
    assert!(n.ephemerides >= 20, "{n:?}");

    let ours = NavFile::read(&nav).unwrap();
    assert_eq!(ours.records.len() as u64, n.ephemerides);
    assert!(ours.skipped.is_empty(), "{:?}", ours.skipped);
    // Subframe 4 page 18 (Klobuchar) comes every 12.5 min: this 9-min part of the log has
    // pages 25–32, 52–54, 57, 60–63 of subframe 4 but not page 18 (convbin read the whole log).
    assert!(ours.gps_iono.is_none());
    let theirs = NavFile::read(&dir.join("16dBatt_no_interference_coldstart.nav.gz")).unwrap();
    let (eo, et) = (
        Ephemerides::from_nav(&[ours]),
        Ephemerides::from_nav(&[theirs]),
    );
    let (mut compared, mut worst_pos, mut worst_clk) = (0, 0.0f64, 0.0f64);
    let mut systems = std::collections::BTreeMap::new();
    for &sv in eo.satellites() {
        for e in eo.of(sv) {
            let Some(t) = et
                .of(sv)
                .iter()
                .find(|t| iode(t) == iode(e) && t.toe() == e.toe())
            else {
                continue;
            };
            for dt in [-3600.0, -1200.0, 0.0, 900.0, 2400.0, 3600.0] {
                let at = e.toe() + Duration::from_seconds(dt);
                let (p, q) = (e.compute(at), t.compute(at));
                worst_pos = worst_pos.max((p.pos.0 - q.pos.0).norm());
                worst_clk = worst_clk.max((p.clock - q.clock).abs());
            }
            assert_eq!(e.healthy(), t.healthy(), "{sv}");
            // convbin prints 12 significant digits, we print 13.
            assert!(
                (e.group_delay(b'1') - t.group_delay(b'1')).abs() < 1e-18,
                "{sv}"
            );
            *systems.entry(sv.sys).or_insert(0) += 1;
            compared += 1;
        }
    }
    eprintln!(
        "{compared} ephemerides compared {systems:?}: worst position {worst_pos:.2e} m, clock \
         {worst_clk:.2e} s"
    );
    // Every ephemeris decoded is in convbin's file (which it made of the whole log).
    assert_eq!(compared as u64, n.ephemerides);
    assert_eq!(systems.get(&Constellation::Gps), Some(&9));
    assert_eq!(systems.get(&Constellation::Galileo), Some(&19));
    assert!(worst_pos < 0.01, "{worst_pos} m");
    assert!(worst_clk * gnss::orbit::C < 0.01, "{worst_clk} s");

    // An independent parser reads the same records.
    let r = rinex::Rinex::from_file(&nav).unwrap();
    assert_eq!(r.nav_ephemeris_frames_iter().count() as u64, n.ephemerides);
}

/// RXM-SFRBX frames (class 0x02, id 0x13) in a UBX byte stream whose Fletcher checksum
/// holds, found by walking the sync characters: a count that owes nothing to the decoder.
fn sfrbx_frames(src: &[u8]) -> u64 {
    let (mut count, mut i) = (0, 0);
    while i + 8 <= src.len() {
        let len = u16::from_le_bytes([src[i + 4], src[i + 5]]) as usize;
        if src[i] != 0xB5 || src[i + 1] != 0x62 || i + 8 + len > src.len() {
            i += 1;
            continue;
        }
        let (mut a, mut b) = (0u8, 0u8);
        for &x in &src[i + 2..i + 6 + len] {
            a = a.wrapping_add(x);
            b = b.wrapping_add(a);
        }
        if (a, b) != (src[i + 6 + len], src[i + 7 + len]) {
            i += 1;
            continue;
        }
        count += u64::from((src[i + 2], src[i + 3]) == (0x02, 0x13));
        i += 8 + len;
    }
    count
}

/// The cold-start log with bits flipped in the first `n` GPS subframes and `n` Galileo
/// pages (frames re-checksummed, so only the navigation checks can catch them).
fn corrupted_log(src: &[u8], n: usize) -> Vec<u8> {
    let (mut out, mut i) = (Vec::with_capacity(src.len()), 0);
    let (mut gps, mut gal) = (0, 0);
    while i + 8 <= src.len() {
        let len = u16::from_le_bytes([src[i + 4], src[i + 5]]) as usize;
        if src[i] != 0xB5 || src[i + 1] != 0x62 || i + 8 + len > src.len() {
            out.push(src[i]);
            i += 1;
            continue;
        }
        let (class, id) = (src[i + 2], src[i + 3]);
        let mut p = src[i + 6..i + 6 + len].to_vec();
        if (class, id) == (0x02, 0x13) && p[0] == 0 && gps < n {
            p[8 + 4 * 3] ^= 0x40; // a data bit of word 4
            gps += 1;
        } else if (class, id) == (0x02, 0x13) && p[0] == 2 && gal < n {
            p[8 + 4 * 2 + 1] ^= 0x10; // a data bit of the even half
            gal += 1;
        }
        out.extend(gnss::raw::ubx::frame(class, id, &p));
        i += 8 + len;
    }
    out.extend_from_slice(&src[i..]);
    out
}

#[test]
fn failed_parity_and_crc_are_counted_not_fatal() {
    let Some(dir) = common::data("gnss/ubx-navsol-2025") else {
        return;
    };
    let src = std::fs::read(dir.join("16dBatt_no_interference_coldstart.ubx")).unwrap();
    let input = tmp("corrupt.ubx");
    std::fs::write(&input, corrupted_log(&src, 7)).unwrap();
    let (obs, nav) = (tmp("corrupt.obs"), tmp("corrupt.nav"));
    let outs = Outputs {
        obs: &obs,
        nav: Some(&nav),
        events: None,
        nmea: None,
    };
    let st = convert(&input, None, None, outs).unwrap();
    assert_eq!(st.checksum_failures, 0);
    assert_eq!((st.nav.parity_failures, st.nav.crc_failures), (7, 7));
    assert_eq!(st.nav.messages, sfrbx_frames(&src));
    // The lost parts come again 30 s later: the same ephemerides result.
    assert_eq!(st.nav.ephemerides, 28);
    assert_eq!(NavFile::read(&nav).unwrap().records.len(), 28);
}
