//! The low-cost bench end to end, as a user runs it: `simulate --builtin lowcost`, then each
//! folder's `ppk --config ppk.toml`, the DJI exposures from the MRK, and the base log's NMEA
//! written as a `.pos` by `convert --nmea`.

use super::*;

/// The walk and the drone processed from their folders by the commands the READMEs give.
#[test]
fn the_low_cost_folders_run_end_to_end() {
    let dir = tmp("lowcost-cli");
    let _ = std::fs::remove_dir_all(&dir);
    let t = succeeds(&ppkat(&["simulate", "--builtin", "lowcost", "-o", p(&dir)]));
    assert!(t.contains("walk →") && t.contains("drone →"), "{t}");

    // The walk shaped on a real pair's fingerprint: what the run found and did is said — how
    // much of it stood still, the code noise it measured, the passes that disagreed, which
    // check refused the fixes.
    let t = succeeds(&ppkat(&["ppk", "--config", p(&dir.join("walk/ppk.toml"))]));
    for said in [
        "stood still at",
        "code noise measured (code minus carrier): rover",
        "phases mended from the satellites' time-differenced fit",
        "lay apart beyond their 99.9 % ellipsoid",
        "codes left out for their post-fit residual",
        "fixes refused at 1201 float epochs, by the check that refused them",
        "float too loose (success rate)",
    ] {
        assert!(t.contains(said), "{said}: {t}");
    }
    assert_eq!(pos_rows(&dir.join("walk/ppk.pos")).len(), 1201);

    // The open-sky walk: the base position from the base log's RTCM 1005, GLONASS float and
    // said so.
    let walk = dir.join("walk-open");
    let t = succeeds(&ppkat(&["ppk", "--config", p(&walk.join("ppk.toml"))]));
    assert!(t.contains("RTCM 1005"), "{t}");
    assert!(t.contains("read as a UBX + RTCM 3 + NMEA log"), "{t}");
    assert!(t.contains("GLONASS ambiguities kept float"), "{t}");
    assert!(
        t.contains("rover epochs fall in gaps of the base's log"),
        "{t}"
    );
    let fixed = pos_rows(&walk.join("ppk.pos"))
        .iter()
        .filter(|r| r.get(5).map(String::as_str) == Some("1"))
        .count();
    assert!(fixed > 1000, "{fixed} fixed epochs of 1201");

    // Interpolation across the base's gaps can be turned off: the same epochs, aged instead.
    let aged = walk.join("aged.pos");
    let t = succeeds(&ppkat(&[
        "ppk",
        "--config",
        p(&walk.join("ppk.toml")),
        "--no-base-interpolation",
        "-o",
        p(&aged),
    ]));
    assert!(!t.contains("fall in gaps of the base's log"), "{t}");
    let (a, b) = (pos_rows(&aged), pos_rows(&walk.join("ppk.pos")));
    assert_eq!(a.len(), b.len());
    assert!(
        a.iter().zip(&b).any(|(x, y)| x[2] != y[2]),
        "aged = interpolated"
    );

    // The base log's own GGA fixes as a .pos, and no checksum failure.
    let (obs, nmea) = (dir.join("base.obs"), dir.join("base_nmea.pos"));
    let t = succeeds(&ppkat(&[
        "convert",
        "--in",
        p(&walk.join("base.ubx")),
        "-o",
        p(&obs),
        "--nmea",
        p(&nmea),
    ]));
    assert!(t.contains(" 0 checksum failures"), "{t}");
    assert_eq!(pos_rows(&nmea).len(), 786, "{t}");

    // The drone: dated with no hint, fixed, its MRK exposures placed.
    let drone = dir.join("drone");
    let t = succeeds(&ppkat(&["ppk", "--config", p(&drone.join("ppk.toml"))]));
    assert!(t.contains("GPS week 2024 by the consensus"), "{t}");
    assert!(t.contains("9 stale ephemerides not used"), "{t}");
    let cams = dir.join("cameras.csv");
    succeeds(&ppkat(&[
        "exposures",
        "--trajectory",
        p(&drone.join("ppk.pos")),
        "--mrk",
        p(&drone.join("Timestamp.MRK")),
        "-o",
        p(&cams),
    ]));
    let rows = std::fs::read_to_string(&cams).unwrap();
    assert_eq!(rows.lines().filter(|l| l.starts_with("DJI_")).count(), 110);
}
