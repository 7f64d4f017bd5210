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

/// `data` with the checksum of each frame of format `F` made right by `fix` (given the whole
/// frame): from the start, a header begins a frame of the length it announces when the input
/// holds all of it, and the search resumes after that frame, or one byte on. A mutation
/// rarely keeps a checksum right, so without this a log's items come only from the seeds'
/// own frames.
pub fn checks_made_right<F: gnss::raw::frames::Framing>(
    data: &[u8],
    fix: impl Fn(&mut [u8]),
) -> Vec<u8> {
    let mut out = data.to_vec();
    let mut i = 0;
    while i + F::HEADER <= out.len() {
        if F::is_sync(out[i]) {
            let look = (out.len() - i).min(F::LOOKAHEAD);
            if let Some(n) = F::frame_len(&out[i..i + look]) {
                if n >= F::HEADER && i + n <= out.len() {
                    fix(&mut out[i..i + n]);
                    i += n;
                    continue;
                }
            }
        }
        i += 1;
    }
    out
}

/// Read `data` as a raw log of `format` (named `name`) when it differs from `right`, its copy
/// with every frame's check made right ([`checks_made_right`]): frames with bad checks, and
/// what lies between frames, as a log reader meets them. An input whose checks were all right
/// is left to the caller, which reads `right`.
pub fn read_as_is_when_changed(
    name: &str,
    data: &[u8],
    right: &[u8],
    format: gnss::raw::RawFormat,
) {
    if right != data {
        with_file(name, data, |p| {
            let _ = gnss::raw::items::for_each_item(p, Some(format), None, |_| {});
        });
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

/// The CSV tables a project names (images, measurements, ground points, antennas), each a
/// small valid one.
pub const PROJECT_TABLES: [(&str, &str); 4] = [
    ("images.csv", "image,strip\n1,1\n2,1\n"),
    (
        "image_observations.csv",
        "image,point,x_px,y_px,sigma_px\n1,G1,983.8,1698.6,0.5\n2,G1,130.2,1669.5,0.5\n1,T1,10,20,0.5\n2,T1,30,40,0.5\n",
    ),
    (
        "ground_points.csv",
        "point,kind,lat_deg,lon_deg,h,sigma_xy,sigma_z\nG1,gcp,47.2911,8.5423,492.1,0.02,0.03\n",
    ),
    (
        "antennas.csv",
        "id,week,tow,lat,lon,h,c_ee,c_en,c_eu,c_nn,c_nu,c_uu,quality,segment\n1,2318,291695.3,47.2913,8.5431,830.09,9.6e-6,0,0,1.3e-5,0,1e-4,1,2\n2,2318,291695.9,47.2915,8.5432,830.08,9.6e-6,0,0,1.3e-5,0,1e-4,1,2\n",
    ),
];

/// The other files a project may name (measured distances, start orientations, PATB image
/// points, a trajectory), each a small valid one.
pub const PROJECT_EXTRAS: [(&str, &str); 4] = [
    ("distances.csv", "point_a,point_b,distance,sigma\nG1,T1,12.5,0.01\n"),
    (
        "start.csv",
        "image,lat,lon,h,omega,phi,kappa\n1,47.2913,8.5431,830.0,0,0,90\n2,47.2915,8.5432,830.0,0,0,90\n",
    ),
    (
        "image_observations.im",
        "1\nG1 0.25 0.1\nT1 -0.5 -0.4\n-99\n2\nG1 0.3 0.2\nT1 -0.4 -0.3\n-99\n",
    ),
    (
        "trajectory.pos",
        "%  GPST                      latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio\n\
         2024/06/12 08:59:59.999800   47.277514885    8.554361153   482.4890   1  11   0.0052   0.0044   0.0149  -0.0017   0.0050   0.0030   0.00  999.9\n\
         2024/06/12 09:00:00.999800   47.277514861    8.554361176   482.4960   1  11   0.0037   0.0031   0.0105  -0.0012   0.0035   0.0021   0.00  999.9\n\
         2024/06/12 09:00:01.999800   47.277514875    8.554361215   482.5105   2  11   0.0037   0.0031   0.0105  -0.0012   0.0035   0.0021   0.00  999.9\n",
    ),
];

/// Write each `(name, text)` of `files` into `dir` unless it is already there, and return
/// their paths: fixed inputs beside the fuzzed one are written once per process, not per run.
pub fn write_fixed<const N: usize>(dir: &Path, files: &[(&str, &str); N]) -> [PathBuf; N] {
    files.map(|(name, text)| {
        let f = dir.join(name);
        if !f.exists() {
            std::fs::write(&f, text).expect("temporary file");
        }
        f
    })
}
