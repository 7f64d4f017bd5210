//! The orbit sources of a run: read the navigation, SP3 and RINEX clock files a job names into
//! one [`Orbits`], and check that they fit the observations.
//!
//! Enters: file paths (navigation files, any number of SP3 files, any number of clock files)
//! and the observation file they are for. Leaves: the [`Orbits`] and warnings for the report,
//! or an error naming the files. Used by [`crate::pipeline`]; prints nothing.

use gnss::error::{Error, Result};
use gnss::orbit::{ClockFile, ClockSource, Ephemerides, Orbits, PreciseOrbits, Sp3};
use gnss::rinex::nav::NavFile;
use gnss::rinex::ObsFile;
use gnss::sv::{Constellation, Sv};
use gnss::time::format_ymdhms;
use std::collections::BTreeSet;
use std::path::PathBuf;

/// Read navigation files, SP3 files and clock files into an orbit source. With SP3 files,
/// satellite positions (and clocks, unless clock files are given) come from them; navigation
/// files are then optional (they still give group delays, ionosphere parameters and GLONASS
/// frequency channels). `from_log` holds the ephemerides decoded from a raw observation log:
/// they are used only when no navigation file is given.
pub fn load_orbits(
    nav: &[PathBuf],
    from_log: Option<&NavFile>,
    sp3: &[PathBuf],
    clk: &[PathBuf],
) -> Result<(Orbits, Vec<String>)> {
    let from_log = from_log.filter(|_| nav.is_empty());
    if nav.is_empty() && sp3.is_empty() && from_log.is_none() {
        return Err(Error::NoData(
            "no orbits: give navigation files (--nav) or SP3 precise orbits (--sp3), or a raw \
             log with navigation subframes"
                .into(),
        ));
    }
    if !clk.is_empty() && sp3.is_empty() {
        return Err(Error::NoData(
            "clock files (--clk) hold satellite clocks only: give the SP3 orbits (--sp3) for the positions".into(),
        ));
    }
    let mut navs = Vec::with_capacity(nav.len());
    for p in nav {
        navs.push(NavFile::read(p)?);
    }
    let mut warnings: Vec<String> = Vec::new();
    if let Some(n) = from_log {
        warnings.push(format!(
            "{}: no navigation file given: using the {} ephemerides decoded from the log's \
             navigation messages",
            n.path.display(),
            n.records.len()
        ));
        navs.push(n.clone());
    }
    let eph = Ephemerides::from_nav(&navs);
    warnings.extend(eph.stats.skipped.iter().cloned());
    if eph.stats.unhealthy > 0 {
        warnings.push(format!(
            "{} ephemerides flagged unhealthy were not used",
            eph.stats.unhealthy
        ));
    }
    if eph.stats.superseded > 0 {
        warnings.push(format!(
            "{} ephemerides of older uploads passed over for later uploads' sets of the same \
             satellites (files that span an upload hold both; they may differ by metres)",
            eph.stats.superseded
        ));
    }
    if eph.stats.unused > 0 {
        warnings.push(format!(
            "{} navigation records of unused message types (SBAS, CNAV …) ignored",
            eph.stats.unused
        ));
    }
    let precise = if sp3.is_empty() {
        None
    } else {
        let files = sp3
            .iter()
            .map(|p| Sp3::read(p))
            .collect::<Result<Vec<_>>>()?;
        let clocks = clk
            .iter()
            .map(|p| ClockFile::read(p))
            .collect::<Result<Vec<_>>>()?;
        for c in clocks.iter().filter(|c| c.unknown_system > 0) {
            warnings.push(format!(
                "{}: {} satellite clock records of systems ppkat does not know ignored",
                c.path.display(),
                c.unknown_system
            ));
        }
        let p = PreciseOrbits::new(&files, &clocks)?;
        warnings.extend(p.warnings.iter().cloned());
        Some(p)
    };
    Ok((
        Orbits {
            broadcast: eph,
            precise,
        },
        warnings,
    ))
}

/// What the code solutions (SPP, PPK start values) miss without broadcast ionosphere
/// parameters or group delays, for the orbits [`load_orbits`] made of `nav` and `from_log`;
/// `None` when nothing is missing. PPP needs neither (ionosphere-free, precise clocks).
pub fn broadcast_warning(
    nav: &[PathBuf],
    from_log: Option<&NavFile>,
    orbits: &Orbits,
) -> Option<String> {
    if nav.is_empty() && from_log.is_none() {
        Some("no navigation file: no Klobuchar ionosphere parameters (ionosphere not modelled, code weights lowered) and no broadcast group delays (TGD) applied to the precise clocks".into())
    } else if orbits.broadcast.gps_iono.is_none() {
        Some("no Klobuchar ionosphere parameters in the navigation data: ionosphere not modelled, code weights lowered".into())
    } else {
        None
    }
}

/// Check that observations and orbits (and precise clocks) overlap in time; error naming the
/// files if not.
pub fn check_overlap(obs: &ObsFile, orbits: &Orbits, nav: &[PathBuf]) -> Result<()> {
    let (Some(a), Some(b)) = (obs.epochs.first(), obs.epochs.last()) else {
        return Ok(());
    };
    let mut spans = Vec::new();
    match (&orbits.precise, orbits.broadcast.span()) {
        (Some(p), _) => {
            spans.push(("orbits", p.span(), p.files.clone()));
            if p.clock_source == ClockSource::ClockFiles {
                let span = p.clock_span().unwrap_or(p.span());
                spans.push(("clocks", span, p.files.clone()));
            }
        }
        (None, Some(span)) => spans.push(("orbits", span, nav.to_vec())),
        (None, None) => {
            return Err(Error::NoData(
                "the navigation files hold no usable ephemeris".into(),
            ))
        }
    }
    let margin = hifitime::Duration::from_seconds(4.0 * 3600.0);
    for (what, (lo, hi), files) in spans {
        if b.time < lo - margin || a.time > hi + margin {
            let names: Vec<String> = files.iter().map(|p| p.display().to_string()).collect();
            return Err(Error::NoData(format!(
                "{}: observations ({} – {}) do not overlap the {what} of {} ({} – {}); give navigation data (or precise orbits and clocks) for the observation days",
                obs.path.display(),
                format_ymdhms(a.time),
                format_ymdhms(b.time),
                names.join(", "),
                format_ymdhms(lo),
                format_ymdhms(hi)
            )));
        }
    }
    Ok(())
}

/// GLONASS satellites observed without a frequency channel (neither the observation header's
/// `GLONASS SLOT / FRQ #` nor a navigation file gives it) cannot be used: a warning naming
/// them, or an error when GLONASS is the only system asked for.
pub fn check_glonass_channels(
    obs: &ObsFile,
    orbits: &Orbits,
    systems: &[Constellation],
) -> Result<Option<String>> {
    if !systems.contains(&Constellation::Glonass) {
        return Ok(None);
    }
    let missing: BTreeSet<Sv> = obs
        .epochs
        .iter()
        .flat_map(|e| e.sats.iter().map(|s| s.sv))
        .filter(|sv| sv.sys == Constellation::Glonass)
        .filter(|sv| {
            obs.header.glonass_channel(*sv).is_none()
                && orbits.broadcast.glonass_channel(sv.prn).is_none()
        })
        .collect();
    if missing.is_empty() {
        return Ok(None);
    }
    let names: Vec<String> = missing.iter().map(|s| s.to_string()).collect();
    let what = format!(
        "{}: GLONASS {} without a frequency channel (the header has no GLONASS SLOT / FRQ # for them and no navigation file gives it): not used; give a navigation file with GLONASS ephemerides (--nav) for their channels",
        obs.path.display(),
        names.join(" ")
    );
    if systems.iter().all(|s| *s == Constellation::Glonass) {
        return Err(Error::NoData(what));
    }
    Ok(Some(what))
}

#[cfg(test)]
mod tests {
    use super::*;
    use gnss::orbit::Ephemerides;

    /// A RINEX 3 file with GPS G05 and GLONASS R05, R07, whose header gives R07's channel only.
    fn obs_file() -> ObsFile {
        let h = |text: &str, label: &str| format!("{text:<60}{label}\n");
        let mut t = h(
            "     3.04           OBSERVATION DATA    M",
            "RINEX VERSION / TYPE",
        );
        t += &h("G    2 C1C L1C", "SYS / # / OBS TYPES");
        t += &h("R    2 C1C L1C", "SYS / # / OBS TYPES");
        t += &h("  1 R07  3", "GLONASS SLOT / FRQ #");
        t += &h(
            "  2024     3    10    12     0    0.0000000     GPS",
            "TIME OF FIRST OBS",
        );
        t += &h("", "END OF HEADER");
        t += "> 2024 03 10 12 00 00.0000000  0  3\n";
        t += "G05  21000000.123 7 110356789.123 7\n";
        t += "R05  21000000.123 7 110356789.123 7\n";
        t += "R07  21000000.123 7 110356789.123 7\n";
        ObsFile::read(&testkit::scratch_file("glonass.rnx", t)).unwrap()
    }

    #[test]
    fn glonass_without_channels_is_named() {
        let obs = obs_file();
        let orbits = Orbits::broadcast(Ephemerides::default());
        use Constellation::{Glonass, Gps};
        assert_eq!(check_glonass_channels(&obs, &orbits, &[Gps]).unwrap(), None);
        let w = check_glonass_channels(&obs, &orbits, &[Gps, Glonass])
            .unwrap()
            .unwrap();
        assert!(w.contains("GLONASS R05 without a frequency channel"), "{w}");
        assert!(w.contains("--nav") && !w.contains("R07"), "{w}");
        let e = check_glonass_channels(&obs, &orbits, &[Glonass]).unwrap_err();
        assert!(e.to_string().contains("glonass.rnx"), "{e}");
    }
}
