//! `ppkat ppk --config FILE.toml` and `--rtklib-conf FILE.conf`: the same run as the flags
//! they stand for, the command line winning over both, and clear errors for bad files.

use super::*;

/// The flags of the reference run (GEONET, 15° mask, forward filter, ratio 2.5, xyz).
const FLAGS: [&str; 8] = [
    GEONET_BASE_POS,
    "--elev-mask",
    "15",
    "--ratio",
    "2.5",
    "--filter",
    "forward",
    "--format=xyz",
];

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let d = tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The reference run with [`FLAGS`] on GEONET's `[rover, base, nav]` into `dir/flags.pos`.
fn flags_run(dir: &Path, [rover, base, nav]: [&Path; 3]) -> PathBuf {
    let by_flags = dir.join("flags.pos");
    let mut args = vec![
        "ppk",
        "--rover",
        p(rover),
        "--base",
        p(base),
        "--nav",
        p(nav),
    ];
    args.extend(FLAGS);
    args.extend(["-o", p(&by_flags)]);
    let t = succeeds(&ppkat(&args));
    // The last epoch (five satellites, its integers held) is fixed since issue 67: 114.
    assert!(t.contains("115 solved, 114 fixed"), "{t}");
    by_flags
}

#[test]
fn a_toml_file_gives_the_same_run_as_its_flags() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let dir = folder("config-toml");
    let by_flags = flags_run(&dir, [&rover, &base, &nav]);

    let cfg = dir.join("flight.toml");
    std::fs::write(
        &cfg,
        format!(
            "# GEONET 2005-04-02\nrover = {:?}\nbase = {:?}\nnav = [{:?}]\n\
             base_pos = [-3978241.958, 3382840.234, 3649900.853]\nelev-mask = 15\n\
             ratio = 2.5\nfilter = \"forward\"\nformat = \"xyz\"\nout = \"by-config.pos\"\n",
            p(&rover),
            p(&base),
            p(&nav)
        ),
    )
    .unwrap();
    let t = succeeds(&ppkat(&["ppk", "--config", p(&cfg)]));
    assert!(t.contains("115 solved, 114 fixed"), "{t}");
    let by_config = dir.join("by-config.pos");
    assert_eq!(
        std::fs::read(&by_flags).unwrap(),
        std::fs::read(&by_config).expect("out read relative to the config file's folder"),
        "a config file gives the very run its flags give"
    );

    // The command line wins: the 10° default mask solves every epoch.
    let over = dir.join("override.pos");
    let t = succeeds(&ppkat(&[
        "ppk",
        "--config",
        p(&cfg),
        "--elev-mask=10",
        "-o",
        p(&over),
    ]));
    assert!(t.contains("120 solved"), "{t}");
    assert!(!dir.join("by-config.pos.tmp").exists());
}

#[test]
fn an_rtklib_conf_gives_the_same_run_and_says_what_it_mapped() {
    let Some([rover, base, nav]) = geonet() else {
        return;
    };
    let dir = folder("config-rtklib");
    let by_flags = flags_run(&dir, [&rover, &base, &nav]);

    // As RTKPOST writes it (names, comments, options ppkat has no use for).
    let conf = dir.join("rtkpost.conf");
    std::fs::write(
        &conf,
        "pos1-posmode       =kinematic  # (0:single,1:dgps,2:kinematic,3:static)\n\
         pos1-frequency     =l1+l2      # (1:l1,2:l1+l2,3:l1+l2+l5)\n\
         pos1-soltype       =forward    # (0:forward,1:backward,2:combined)\n\
         pos1-elmask        =15         # (deg)\n\
         pos1-snrmask_r     =off        # (0:off,1:on)\n\
         pos1-navsys        =41         # (1:gps+2:sbas+4:glo+8:gal+16:qzs+32:bds)\n\
         pos2-armode        =fix-and-hold # (0:off,1:continuous,2:instantaneous,3:fix-and-hold)\n\
         pos2-arthres       =2.5\n\
         pos2-slipthres     =0.05       # (m)\n\
         out-solformat      =xyz        # (0:llh,1:xyz,2:enu,3:nmea)\n\
         ant2-postype       =xyz        # (0:llh,1:xyz,2:single,3:posfile,4:rinexhead)\n\
         ant2-pos1          =-3978241.958 # (deg|m)\n\
         ant2-pos2          =3382840.234 # (deg|m)\n\
         ant2-pos3          =3649900.853 # (m|m)\n",
    )
    .unwrap();
    let out = dir.join("by-conf.pos");
    let o = ppkat(&[
        "ppk",
        "--rtklib-conf",
        p(&conf),
        "--rover",
        p(&rover),
        "--base",
        p(&base),
        "--nav",
        p(&nav),
        "--systems",
        "G,E,C,J,R",
        "-o",
        p(&out),
    ]);
    let t = succeeds(&o);
    assert!(t.contains("RTKLIB option(s) mapped"), "{t}");
    assert!(t.contains("pos1-elmask=15 → --elev-mask 15"), "{t}");
    assert!(
        t.contains("2 RTKLIB option(s) ignored: pos1-snrmask_r=off")
            && t.contains("pos2-slipthres=0.05 (no equivalent"),
        "{t}"
    );
    assert_eq!(
        std::fs::read(&by_flags).unwrap(),
        std::fs::read(&out).unwrap(),
        "the RTKLIB options give the run of the flags they map to"
    );
}

#[test]
fn bad_option_files_are_errors_naming_the_file() {
    let dir = folder("config-bad");
    let cfg = dir.join("typo.toml");
    std::fs::write(&cfg, "rover = \"r.obs\"\nelev_mak = 15\n").unwrap();
    let o = ppkat(&["ppk", "--config", p(&cfg)]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "bad usage: {t}");
    assert!(t.contains("typo.toml") && t.contains("'elev_mak'") && t.contains("elev-mask"));
    assert_eq!(t.lines().count(), 1, "one line: {t}");

    std::fs::write(&cfg, "rover = [1, \n").unwrap();
    let o = ppkat(&["ppk", "--config", p(&cfg)]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(2), "{t}");
    assert!(t.contains("typo.toml") && t.contains("line"), "{t}");

    let o = ppkat(&["ppk", "--config", p(&dir.join("absent.toml"))]);
    fails_with(&o, &["cannot read the options file", "absent.toml"]);
}
