//! `ppkat ppk --rtklib-conf FILE.conf`: the options of an RTKLIB configuration file (as
//! rnx2rtkp and RTKPOST write them, `key =value # comment`) mapped to the flags of `ppkat ppk`.
//!
//! Enumerated values are read by name or by number, as RTKLIB reads them. Only options with
//! an equivalent are mapped; every other one is listed as ignored, so nothing is dropped
//! silently.

use std::collections::BTreeMap;
use std::path::Path;

/// One option for a command, as the flag that sets it.
#[derive(Clone, Debug, PartialEq)]
pub struct Setting {
    /// Long flag name without dashes, e.g. `elev-mask`.
    pub flag: String,
    /// The values: one per repetition of a list flag, else one (`"true"` for a switch).
    pub values: Vec<String>,
}

/// A path from an options file: relative ones are read from the file's folder `dir`.
pub fn resolve(dir: &Path, path: &str) -> String {
    let p = Path::new(path);
    if p.is_relative() && !dir.as_os_str().is_empty() {
        dir.join(p).to_string_lossy().to_string()
    } else {
        path.to_string()
    }
}

/// What a configuration file sets: the flags, and the notes on what was mapped and ignored.
#[derive(Debug, Default)]
pub struct Mapped {
    /// The flags the file's options stand for.
    pub settings: Vec<Setting>,
    /// "key=value → --flag value" for each option mapped.
    pub mapped: Vec<String>,
    /// "key=value (why)" for each option with no equivalent or a value not understood.
    pub ignored: Vec<String>,
}

impl Mapped {
    /// The notes to print: what was mapped and what was ignored, naming the file.
    pub fn notes(&self, file: &Path) -> Vec<String> {
        let mut n = vec![format!(
            "{}: {} RTKLIB option(s) mapped: {}",
            file.display(),
            self.mapped.len(),
            self.mapped.join("; ")
        )];
        if !self.ignored.is_empty() {
            n.push(format!(
                "{}: {} RTKLIB option(s) ignored: {}",
                file.display(),
                self.ignored.len(),
                self.ignored.join("; ")
            ));
        }
        n
    }

    /// Set `--flag to` for the option `key=value`.
    fn set(&mut self, key: &str, value: &str, flag: &str, to: String) {
        self.mapped.push(format!("{key}={value} → --{flag} {to}"));
        self.settings.retain(|s| s.flag != flag);
        self.settings.push(Setting {
            flag: flag.to_string(),
            values: vec![to],
        });
    }

    /// List `key=value` as ignored, with the reason.
    fn ignore(&mut self, key: &str, value: &str, why: &str) {
        self.ignored.push(format!("{key}={value} ({why})"));
    }
}

/// The options of an RTKLIB configuration file, keyed by name (last one wins, as in RTKLIB).
fn options(text: &str) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    for line in text.lines() {
        let line = line.split('#').next().unwrap_or("");
        if let Some((k, v)) = line.split_once('=') {
            let (k, v) = (k.trim(), v.trim());
            if !k.is_empty() {
                out.insert(k.to_string(), v.to_string());
            }
        }
    }
    out
}

/// An RTKLIB enumeration value, by name or number; `names` lists the names by number.
fn enumerated(value: &str, names: &[&str]) -> Option<usize> {
    names
        .iter()
        .position(|n| n.eq_ignore_ascii_case(value))
        .or_else(|| value.parse::<usize>().ok().filter(|i| *i < names.len()))
}

/// A finite number.
fn number(value: &str) -> Option<f64> {
    value.parse::<f64>().ok().filter(|v| v.is_finite())
}

/// Map an RTKLIB configuration file's text to flags; relative file names are taken from
/// `dir`, the file's folder.
pub fn map(text: &str, dir: &Path) -> Mapped {
    let opts = options(text);
    let mut m = Mapped::default();
    for (key, value) in &opts {
        if value.is_empty() {
            continue;
        }
        if !map_one(&mut m, key, value, dir) {
            m.ignore(key, value, "no equivalent in ppkat ppk");
        }
    }
    base_position(&mut m, &opts);
    m
}

/// Map one option; false when ppkat has no equivalent of the option at all.
fn map_one(m: &mut Mapped, key: &str, value: &str, dir: &Path) -> bool {
    let bad = |m: &mut Mapped| m.ignore(key, value, "value not understood");
    match key {
        "pos1-posmode" => posmode(m, key, value),
        "pos1-frequency" => match frequencies(value) {
            Some(n) => m.set(key, value, "frequencies", n.to_string()),
            None => bad(m),
        },
        "pos1-soltype" => {
            const T: [&str; 4] = ["forward", "backward", "combined", "combined-nophasereset"];
            match enumerated(value, &T) {
                Some(i) => m.set(key, value, "filter", T[i.min(2)].to_string()),
                None => bad(m),
            }
        }
        "pos1-elmask" | "pos2-arelmask" | "pos2-arthres" | "pos2-maxage" | "stats-eratio1"
        | "pos2-arlockcnt" => {
            let flag = match key {
                "pos1-elmask" => "elev-mask",
                "pos2-arelmask" => "ar-elev-mask",
                "pos2-arthres" => "ratio",
                "pos2-maxage" => "max-age",
                "stats-eratio1" => "code-phase-ratio",
                _ => "min-lock",
            };
            match number(value) {
                Some(v) => m.set(key, value, flag, v.to_string()),
                None => bad(m),
            }
        }
        "pos1-ionoopt" => atmosphere(m, key, value, "iono", 4, 7),
        "pos1-tropopt" => atmosphere(m, key, value, "tropo", 3, 5),
        "pos1-navsys" => navsys(m, key, value),
        "pos2-armode" => {
            const A: [&str; 4] = ["off", "continuous", "instantaneous", "fix-and-hold"];
            match enumerated(value, &A) {
                Some(i) => m.set(key, value, "ar", A[i].to_string()),
                None => bad(m),
            }
        }
        "stats-errphase" | "stats-errphaseel" => phase_sigma(m, key, value),
        "out-solformat" => match enumerated(value, &["llh", "xyz", "enu", "nmea"]) {
            Some(0) => m.set(key, value, "format", "llh".into()),
            Some(1) => m.set(key, value, "format", "xyz".into()),
            Some(_) => m.ignore(key, value, "only llh and xyz .pos files are written"),
            None => bad(m),
        },
        "out-height" => match enumerated(value, &["ellipsoidal", "geodetic"]) {
            Some(0) => m.set(key, value, "height", "ellipsoidal".into()),
            Some(_) => m.set(key, value, "height", "egm96".into()),
            None => bad(m),
        },
        "file-rcvantfile" => m.set(key, value, "antex", resolve(dir, value)),
        k if k.starts_with("ant2-pos") || k == "ant2-postype" => {}
        _ => return false,
    }
    true
}

/// `pos1-posmode`: kinematic and static map to `--mode`; other modes are other commands.
fn posmode(m: &mut Mapped, key: &str, value: &str) {
    match value.to_ascii_lowercase().as_str() {
        "kinematic" | "2" => m.set(key, value, "mode", "kinematic".into()),
        "static" | "3" => m.set(key, value, "mode", "static".into()),
        _ => m.ignore(
            key,
            value,
            "ppkat ppk does kinematic and static; single is `ppkat spp`, ppp-* is `ppkat ppp`",
        ),
    }
}

/// `pos1-frequency` (l1, l1+l2, l1+l2+l5, … or 1–4) as the number of frequencies, at most 3.
fn frequencies(value: &str) -> Option<usize> {
    if let Ok(n) = value.parse::<usize>() {
        return (1..=4).contains(&n).then_some(n.min(3));
    }
    let bands: Vec<&str> = value.split('+').collect();
    let known = bands
        .iter()
        .all(|b| ["l1", "l2", "l5", "l6"].contains(&b.to_ascii_lowercase().as_str()));
    (known && bands.first().is_some_and(|b| b.eq_ignore_ascii_case("l1")))
        .then_some(bands.len().min(3))
}

/// `pos1-ionoopt` / `pos1-tropopt` (`count` names): the estimating choices (from index
/// `first`; est-stec for the ionosphere) map to `on`, the model-only ones to `off`.
fn atmosphere(m: &mut Mapped, key: &str, value: &str, flag: &str, first: usize, count: usize) {
    const IONO: [&str; 7] = [
        "off",
        "brdc",
        "sbas",
        "dual-freq",
        "est-stec",
        "ionex-tec",
        "qzs-brdc",
    ];
    const TROPO: [&str; 5] = ["off", "saas", "sbas", "est-ztd", "est-ztdgrad"];
    let names: &[&str] = if flag == "iono" { &IONO } else { &TROPO };
    match enumerated(value, &names[..count]) {
        Some(i) if flag == "iono" && (i == 3 || i == 5) => m.ignore(
            key,
            value,
            "no iono-free or IONEX model; --iono auto (estimated beyond 10 km) stays",
        ),
        Some(i) if i >= first && !(flag == "iono" && i > 4) => m.set(key, value, flag, "on".into()),
        Some(_) => m.set(key, value, flag, "off".into()),
        None => m.ignore(key, value, "value not understood"),
    }
}

/// `pos1-navsys`, RTKLIB's bit mask (1 GPS, 2 SBAS, 4 GLONASS, 8 Galileo, 16 QZSS, 32
/// BeiDou, 64 NavIC), as `--systems`.
fn navsys(m: &mut Mapped, key: &str, value: &str) {
    let Ok(mask) = value.parse::<u32>() else {
        return m.ignore(key, value, "value not understood");
    };
    let letters: Vec<&str> = [(1, "G"), (8, "E"), (32, "C"), (16, "J"), (4, "R")]
        .iter()
        .filter(|(bit, _)| mask & bit != 0)
        .map(|(_, l)| *l)
        .collect();
    if letters.is_empty() {
        return m.ignore(key, value, "no system ppkat uses");
    }
    m.set(key, value, "systems", letters.join(","));
    if mask & (2 | 64) != 0 {
        m.ignore(key, value, "SBAS and NavIC are not used");
    }
}

/// `stats-errphase` (a) and `stats-errphaseel` (b), both RTKLIB's default 0.003 m, as
/// `--phase-sigma a,b`.
fn phase_sigma(m: &mut Mapped, key: &str, value: &str) {
    let Some(v) = number(value).filter(|v| *v >= 0.0) else {
        return m.ignore(key, value, "value not understood");
    };
    let (mut a, mut b) = m
        .settings
        .iter()
        .find(|s| s.flag == "phase-sigma")
        .and_then(|s| s.values[0].split_once(','))
        .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
        .unwrap_or((0.003, 0.003));
    if key == "stats-errphase" {
        a = v;
    } else {
        b = v;
    }
    m.set(key, value, "phase-sigma", format!("{a},{b}"));
}

/// `ant2-postype` with `ant2-pos1/2/3`: the base position as `--base-llh` or `--base-pos`.
fn base_position(m: &mut Mapped, opts: &BTreeMap<String, String>) {
    let Some(kind) = opts.get("ant2-postype") else {
        return;
    };
    const P: [&str; 7] = [
        "llh",
        "xyz",
        "single",
        "posfile",
        "rinexhead",
        "rtcm",
        "raw",
    ];
    let pos: Option<Vec<f64>> = (1..=3)
        .map(|i| opts.get(&format!("ant2-pos{i}")).and_then(|v| number(v)))
        .collect();
    let key = "ant2-postype";
    match (enumerated(kind, &P), pos) {
        (Some(0), Some(p)) => {
            let to = format!("{},{},{}", p[0], p[1], p[2]);
            m.set(key, kind, "base-llh", to);
        }
        (Some(1), Some(p)) => {
            let to = format!("{},{},{}", p[0], p[1], p[2]);
            m.set(key, kind, "base-pos", to);
        }
        (Some(4), _) => m.mapped.push(format!(
            "{key}={kind} → the base file's header position (the default)"
        )),
        (Some(0 | 1), None) => m.ignore(key, kind, "ant2-pos1/2/3 missing or not numbers"),
        _ => m.ignore(
            key,
            kind,
            "give the base position with --base-pos/--base-llh, or --base-from-ppp",
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flags(m: &Mapped) -> Vec<(String, String)> {
        let mut v: Vec<_> = m
            .settings
            .iter()
            .map(|s| (s.flag.clone(), s.values.join("|")))
            .collect();
        v.sort();
        v
    }

    /// Lines as RTKPOST writes them (names with comments) and as people edit them (numbers).
    #[test]
    fn a_written_configuration_maps_to_flags() {
        let text = "\
pos1-posmode       =kinematic  # (0:single,1:dgps,2:kinematic,3:static,4:static-start,...)
pos1-frequency     =l1+l2      # (1:l1,2:l1+l2,3:l1+l2+l5,4:l1+l2+l5+l6)
pos1-soltype       =combined   # (0:forward,1:backward,2:combined)
pos1-elmask        =15         # (deg)
pos1-snrmask_r     =off        # (0:off,1:on)
pos1-ionoopt       =brdc       # (0:off,1:brdc,2:sbas,3:dual-freq,4:est-stec,...)
pos1-tropopt       =3          # est-ztd
pos1-navsys        =41         # (1:gps+2:sbas+4:glo+8:gal+16:qzs+32:bds)
pos2-armode        =fix-and-hold
pos2-arthres       =2.5
pos2-arelmask      =20
pos2-maxage        =10
stats-eratio1      =300
stats-errphaseel   =0.004
out-solformat      =xyz
out-height         =geodetic
ant2-postype       =llh
ant2-pos1          =35.6
ant2-pos2          =139.7
ant2-pos3          =70.25
file-rcvantfile    =igs14.atx
misc-timeinterp    =on
";
        let m = map(text, Path::new("/conf"));
        assert_eq!(
            flags(&m),
            [
                ("antex", "/conf/igs14.atx"),
                ("ar", "fix-and-hold"),
                ("ar-elev-mask", "20"),
                ("base-llh", "35.6,139.7,70.25"),
                ("code-phase-ratio", "300"),
                ("elev-mask", "15"),
                ("filter", "combined"),
                ("format", "xyz"),
                ("frequencies", "2"),
                ("height", "egm96"),
                ("iono", "off"),
                ("max-age", "10"),
                ("mode", "kinematic"),
                ("phase-sigma", "0.003,0.004"),
                ("ratio", "2.5"),
                ("systems", "G,E,C"),
                ("tropo", "on"),
            ]
            .map(|(a, b)| (a.to_string(), b.to_string()))
        );
        let ignored = m.ignored.join("\n");
        assert!(
            ignored.contains("pos1-snrmask_r=off (no equivalent"),
            "{ignored}"
        );
        assert!(ignored.contains("misc-timeinterp=on"), "{ignored}");
        assert_eq!(m.ignored.len(), 2, "{ignored}");
    }

    #[test]
    fn other_modes_bad_values_and_header_positions_are_said() {
        let m = map(
            "pos1-posmode=ppp-kine\npos1-elmask=high\npos1-ionoopt=dual-freq\n\
             ant2-postype=rinexhead\npos1-navsys=7\npos1-frequency=l2\n",
            Path::new(""),
        );
        assert_eq!(
            flags(&m),
            [("systems".to_string(), "G,R".to_string())],
            "{m:?}"
        );
        let ignored = m.ignored.join("\n");
        for needle in [
            "pos1-posmode=ppp-kine (ppkat ppk does kinematic and static",
            "pos1-elmask=high (value not understood)",
            "pos1-ionoopt=dual-freq (no iono-free",
            "pos1-navsys=7 (SBAS and NavIC",
            "pos1-frequency=l2 (value not understood)",
        ] {
            assert!(ignored.contains(needle), "{needle}: {ignored}");
        }
        assert!(m.mapped.iter().any(|s| s.contains("header position")));
    }
}
