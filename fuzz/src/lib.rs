//! What every fuzz target shares: the parsers read files, so the input is written to a file of
//! this process first.

use std::path::{Path, PathBuf};

/// Write `data` to a file of this process named `name` and run `f` on its path.
pub fn with_file<T>(name: &str, data: &[u8], f: impl FnOnce(&Path) -> T) -> T {
    static SWEPT: std::sync::Once = std::sync::Once::new();
    SWEPT.call_once(sweep_dead);
    let dir = std::env::temp_dir().join(format!("ppkat-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary folder");
    let path: PathBuf = dir.join(name);
    std::fs::write(&path, data).expect("temporary file");
    f(&path)
}

/// Remove the folders of fuzzing processes that have ended (a fuzzer ends by exiting, so it
/// cannot remove its own): each is named by a process id that `/proc` no longer lists.
fn sweep_dead() {
    let Ok(entries) = std::fs::read_dir(std::env::temp_dir()) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let Some(pid) = name.to_str().and_then(|n| n.strip_prefix("ppkat-fuzz-")) else {
            continue;
        };
        if pid.parse::<u32>().is_ok() && !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(e.path());
        }
    }
}

/// What a command does with a raw log's items after decoding: time marks put in RINEX order
/// among the epochs, and ephemerides loaded and evaluated as `spp`/`ppk` would.
pub fn use_items(path: &Path, format: gnss::raw::RawFormat, hint: Option<gnss::raw::TimeHint>) {
    use gnss::raw::items::{for_each_item, RawItem};
    let mut order = gnss::raw::records::RinexOrder::default();
    let mut nav = gnss::rinex::nav::NavFile::default();
    let _ = for_each_item(path, Some(format), hint, |it| {
        if let RawItem::Ephemeris(r) = &it {
            if nav.records.len() < 256 {
                nav.records.push(r.clone());
            }
        }
        let _ = order.item(it, &mut |_| Ok::<(), ()>(()));
    });
    let _ = order.finish(&mut |_| Ok::<(), ()>(()));
    evaluate(&[nav]);
}

/// Ephemerides of `navs` loaded, and every one evaluated at its toe and two hours around it.
pub fn evaluate(navs: &[gnss::rinex::nav::NavFile]) {
    let e = gnss::orbit::Ephemerides::from_nav(navs);
    let svs: Vec<_> = e.satellites().copied().collect();
    for sv in svs {
        for eph in e.of(sv) {
            for dt in [0.0, -7200.0, 7200.0] {
                let _ = eph.position_clock(eph.toe() + hifitime::Duration::from_seconds(dt));
            }
        }
    }
}
