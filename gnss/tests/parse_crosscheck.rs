//! Every observation file of the shared data parses, and agrees epoch by epoch with an
//! independent parser (the `rinex` crate): epoch times, satellites per epoch, number of
//! observation values and their sum (which catches any decoding slip, Hatanaka included).

mod common;

use gnss::rinex::ObsFile;
use std::collections::BTreeSet;

const FILES: [&str; 8] = [
    "gnss/geonet-2005/07590920.05o",
    "gnss/geonet-2005/30400920.05o",
    "gnss/cssrlib-2021-265/3034265G.21O",
    "gnss/cssrlib-2021-265/SEPT265G.21O",
    "gnss/spirent-rose-2023/Base-static_MO_Spirent.obs",
    "gnss/spirent-rose-2023/Rover-dynamic_MO_Spirent.obs",
    "gnss/spirent-rose-2023/Rover-static-2km-east_MO_Spirent.obs",
    "gnss/esbc-2020-177/ESBC00DNK_R_20201770000_01D_30S_MO.crx.gz",
];

#[test]
fn all_observation_files_agree_with_an_independent_parser() {
    for rel in FILES {
        let Some(path) = common::data(rel) else {
            return;
        };
        let ours = ObsFile::read(&path).unwrap_or_else(|e| panic!("{rel}: {e}"));
        assert!(
            ours.warnings.is_empty(),
            "{rel}: {:?}",
            &ours.warnings[..ours.warnings.len().min(3)]
        );
        let theirs = if rel.ends_with(".gz") {
            rinex::Rinex::from_gzip_file(&path)
        } else {
            rinex::Rinex::from_file(&path)
        }
        .unwrap_or_else(|e| panic!("{rel}: the reference parser fails: {e:?}"));
        let rec = theirs.record.as_obs().expect("observation record");
        let theirs: Vec<_> = rec
            .iter()
            .filter(|(k, _)| k.flag.is_ok() || format!("{:?}", k.flag) == "PowerFailure")
            .collect();
        assert_eq!(ours.epochs.len(), theirs.len(), "{rel}: epoch count");
        let mut values = 0usize;
        for (e, (k, o)) in ours.epochs.iter().zip(theirs.iter()) {
            let dt = (e.time - k.epoch.to_time_scale(hifitime::TimeScale::GPST)).to_seconds();
            assert!(
                dt.abs() < 1e-6,
                "{rel}: epoch time {} vs {}",
                e.time,
                k.epoch
            );
            let our_svs: BTreeSet<String> = e
                .sats
                .iter()
                .filter(|s| s.obs.iter().any(|o| o.is_present()))
                .map(|s| s.sv.to_string())
                .collect();
            // The reference parser names SBAS satellites after the spacecraft ("SES-5").
            let their_svs: BTreeSet<String> = o
                .signals
                .iter()
                .map(|s| {
                    let n = s.sv.to_string();
                    if n.len() == 3 {
                        n
                    } else {
                        format!("S{:02}", s.sv.prn)
                    }
                })
                .collect();
            assert_eq!(our_svs, their_svs, "{rel}: satellites at {}", e.time);
            let ours_vals: Vec<f64> = e
                .sats
                .iter()
                .flat_map(|s| s.obs.iter())
                .filter(|o| o.is_present())
                .map(|o| o.value)
                .collect();
            assert_eq!(
                ours_vals.len(),
                o.signals.len(),
                "{rel}: values at {}",
                e.time
            );
            let a: f64 = ours_vals.iter().sum();
            let b: f64 = o.signals.iter().map(|s| s.value).sum();
            assert!(
                (a - b).abs() <= 1e-6 * a.abs().max(1.0),
                "{rel}: value sum at {}: {a} vs {b}",
                e.time
            );
            values += ours_vals.len();
        }
        eprintln!("{rel}: {} epochs, {values} values agree", ours.epochs.len());
    }
}
