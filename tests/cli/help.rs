//! `--help` of every subcommand, and clap's exit code 2 for bad usage.

use super::*;

/// Every subcommand, as its words on the command line.
const SUBCOMMANDS: [&[&str]; 20] = [
    &["info"],
    &["convert"],
    &["spp"],
    &["ppk"],
    &["ppp"],
    &["exposures"],
    &["leverarm"],
    &["bal"],
    &["simulate"],
    &["adjust"],
    &["import"],
    &["import", "micmac"],
    &["import", "colmap"],
    &["import", "patb"],
    &["demo"],
    &["bench"],
    &["bench", "ingest"],
    &["bench", "ppk"],
    &["bench", "adjust"],
    &["bench", "match"],
];

/// In the long help, each option or positional line (`  -o, --out <OUT>`, `  <FILE>`) is
/// followed by its description; the options `-h` and `-V` too.
#[test]
fn every_argument_of_every_subcommand_is_described() {
    for words in SUBCOMMANDS {
        let mut args = words.to_vec();
        args.push("--help");
        let t = succeeds(&ppkat(&args));
        let name = words.join(" ");
        assert!(t.contains(&format!("Usage: ppkat {name}")), "{t}");
        let lines: Vec<&str> = t.lines().collect();
        let arg_lines = lines.iter().enumerate().filter(|(_, l)| {
            let l = l.trim_start();
            let short = l.starts_with('-') && l.get(2..4) == Some(", ");
            (l.starts_with("--") || short || l.starts_with('<')) && l.len() < 60
        });
        let mut seen = 0;
        for (i, l) in arg_lines {
            seen += 1;
            let next = lines.get(i + 1).map(|n| n.trim()).unwrap_or("");
            assert!(
                !next.is_empty(),
                "ppkat {name}: '{}' has no help:\n{t}",
                l.trim()
            );
        }
        assert!(seen >= 2, "ppkat {name}: no arguments found in\n{t}");
        assert!(
            t.contains("--threads <N>"),
            "ppkat {name}: no --threads\n{t}"
        );
    }
    // The flags the issue named, with their texts.
    let t = succeeds(&ppkat(&["ppk", "--help"]));
    for needle in [
        "--rover <FILE>\n          Observation file of the moving receiver: RINEX, or a raw receiver log (u-blox UBX, RTCM 3, Septentrio SBF)",
        "--base <FILE>\n          Observation file of the base (reference) receiver: RINEX, or a raw receiver log (u-blox UBX, RTCM 3, Septentrio SBF)",
        "--obs-format <FORMAT>\n          Format of both observation files",
        "--format <FORMAT>\n          Layout of the output",
        "-o, --out <OUT.pos>\n          Output file",
        "--report <OUT.html>\n          Also write a quality report",
    ] {
        assert!(t.contains(needle), "no '{needle}' in\n{t}");
    }
    // Every command writing an output folder takes -o.
    for cmd in [
        &["demo"][..],
        &["simulate"],
        &["adjust"],
        &["bench", "adjust"],
        &["bench", "match"],
    ] {
        let mut args = cmd.to_vec();
        args.push("--help");
        let t = succeeds(&ppkat(&args));
        assert!(
            t.contains("-o, --out <DIR>"),
            "ppkat {cmd:?}: no -o in\n{t}"
        );
    }
    // Precise orbits and clocks, repeatable, for both positioning commands.
    for cmd in ["spp", "ppk"] {
        let t = succeeds(&ppkat(&[cmd, "--help"]));
        for needle in [
            "--sp3 <FILE>\n          Precise orbits and clocks (SP3-a/b/c/d",
            "--clk <FILE>\n          RINEX clock file",
            "Required unless --sp3 is given",
            "give the flag once per file",
        ] {
            assert!(t.contains(needle), "ppkat {cmd}: no '{needle}' in\n{t}");
        }
    }
}

#[test]
fn bad_usage_exits_with_2() {
    for args in [
        &["nosuch"][..],
        &["ppk", "--rover"],
        &["spp", "--obs", "x.obs"],
        &["ppk", "--format", "nosuch"],
        &["--threads", "0", "info", "x.obs"],
        &["bal", "x.bal", "--threads", "many"],
        &[],
    ] {
        let o = ppkat(args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", text(&o));
    }
    let o = ppkat(&["--threads", "0", "info", "x.obs"]);
    assert!(text(&o).contains("1 or more"), "{}", text(&o));
}

#[test]
fn threads_is_accepted_before_and_after_any_subcommand() {
    let f = fixture("events_v304.rnx");
    for args in [
        &["--threads", "1", "info", p(&f)][..],
        &["info", p(&f), "--threads", "2"],
    ] {
        let t = succeeds(&ppkat(args));
        assert!(t.contains("RINEX 3.04 observation"), "{t}");
    }
}

/// `simulate --help` names every built-in adjustment project, the textured block among them.
#[test]
fn simulate_help_names_every_builtin_project() {
    let t = succeeds(&ppkat(&["simulate", "--help"]));
    for b in integration::simulate::block::BUILTINS {
        assert!(t.contains(b), "no {b} in\n{t}");
    }
    assert!(
        t.contains("photos/<image id>.png") && t.contains("camera.toml"),
        "{t}"
    );
}
