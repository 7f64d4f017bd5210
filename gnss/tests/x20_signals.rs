//! A dual-band u-blox X20-class log (the walk of `ins/rtklibexplorer-gnss-imu-2025`) tracks
//! BeiDou B1C and B3I and Galileo E6 beside L1/L2/L5, E1/E5a and B2a: they are written in
//! their RINEX 3.04 slots (1P, 6I, 6B), not dropped for want of one (issue 67: 9,590 + 2,932
//! measurements were dropped before).

use gnss::obs::read_obs;
use gnss::sv::Constellation::{self, BeiDou, Galileo};

#[test]
fn b1c_b3i_and_e6_are_kept() {
    let Some(log) =
        testkit::shared_data("ins/rtklibexplorer-gnss-imu-2025/walk_0827/gnss_1730.ubx")
    else {
        return;
    };
    let input = read_obs(&log, None, None).unwrap();
    let st = input.raw.as_ref().unwrap();
    let count = |sys: Constellation, code: &[u8; 3]| -> usize {
        let Some(types) = input.obs.header.obs_types.get(&sys) else {
            return 0;
        };
        let Some(k) = types.iter().position(|t| &t.0 == code) else {
            return 0;
        };
        input
            .obs
            .epochs
            .iter()
            .flat_map(|e| &e.sats)
            .filter(|s| s.sv.sys == sys && s.get(k).is_present())
            .count()
    };
    let (b1c, b3i, e6) = (
        count(BeiDou, b"C1P"),
        count(BeiDou, b"C6I"),
        count(Galileo, b"C6B"),
    );
    println!("B1C pilot {b1c}, B3I {b3i}, E6-B {e6} code observations; {st}");
    // The counts of what was dropped before, each signal at one code per satellite-epoch.
    assert_eq!(b1c, 4174);
    assert_eq!(b3i, 5416);
    assert_eq!(e6, 2932);
    assert!(!st.to_string().contains("no RINEX 3 slot"), "{st}");
}
