//! Where PROJ and GeographicLib keep their geoid grids, for `--height egm2008`: PROJ's data
//! folders (`PROJ_DATA`, or `PROJ_LIB` before PROJ 9.1, each a `:`-separated list; the user
//! folder `$XDG_DATA_HOME/proj` or `~/.local/share/proj`; `/usr/local/share/proj`,
//! `/usr/share/proj`, `/opt/homebrew/share/proj`) and GeographicLib's (`GEOGRAPHICLIB_GEOID_PATH`,
//! `$GEOGRAPHICLIB_DATA/geoids`, `/usr/local/share/GeographicLib/geoids`,
//! `/usr/share/GeographicLib/geoids`). Folders in that order (a folder the user named
//! first), and in a folder the finest grid; the file used is named in every header that
//! states the heights.

use std::path::{Path, PathBuf};

/// EGM2008 grids by preference (finest and least quantised first): NGA's raw 1′ grid,
/// GeographicLib's 1′ PGM, PROJ's 2.5′ GeoTIFF and GTX, NGA's raw 2.5′ grid, GeographicLib's
/// 2.5′ and 5′ PGMs.
pub const EGM2008_FILES: [&str; 7] = [
    "Und_min1x1_egm2008_isw=82_WGS84_TideFree_SE",
    "egm2008-1.pgm",
    "us_nga_egm08_25.tif",
    "egm08_25.gtx",
    "Und_min2.5x2.5_egm2008_isw=82_WGS84_TideFree_SE",
    "egm2008-2_5.pgm",
    "egm2008-5.pgm",
];

/// The folders searched, in order, with the environment read through `var`.
pub fn folders(var: &dyn Fn(&str) -> Option<String>) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let list = |name: &str, out: &mut Vec<PathBuf>| {
        if let Some(v) = var(name) {
            out.extend(v.split(':').filter(|s| !s.is_empty()).map(PathBuf::from));
        }
    };
    list("PROJ_DATA", &mut out);
    list("PROJ_LIB", &mut out);
    if let Some(x) = var("XDG_DATA_HOME").filter(|s| !s.is_empty()) {
        out.push(Path::new(&x).join("proj"));
    } else if let Some(h) = var("HOME").filter(|s| !s.is_empty()) {
        out.push(Path::new(&h).join(".local/share/proj"));
    }
    for d in [
        "/usr/local/share/proj",
        "/usr/share/proj",
        "/opt/homebrew/share/proj",
    ] {
        out.push(PathBuf::from(d));
    }
    list("GEOGRAPHICLIB_GEOID_PATH", &mut out);
    if let Some(d) = var("GEOGRAPHICLIB_DATA").filter(|s| !s.is_empty()) {
        out.push(Path::new(&d).join("geoids"));
    }
    for d in [
        "/usr/local/share/GeographicLib/geoids",
        "/usr/share/GeographicLib/geoids",
    ] {
        out.push(PathBuf::from(d));
    }
    let mut seen = std::collections::BTreeSet::new();
    out.retain(|p| seen.insert(p.clone()));
    out
}

/// The first of `names` found in `folders`: folders in order, and in a folder names in
/// order of preference.
pub fn first(names: &[&str], folders: &[PathBuf]) -> Option<PathBuf> {
    folders
        .iter()
        .flat_map(|f| names.iter().map(move |n| f.join(n)))
        .find(|p| p.is_file())
}

/// What to do when no EGM2008 grid is found: where it was looked for and where to put one.
pub fn not_found(folders: &[PathBuf]) -> String {
    let user = folders
        .iter()
        .find(|f| f.ends_with("proj") && !f.starts_with("/usr") && !f.starts_with("/opt"))
        .map_or("~/.local/share/proj".to_string(), |f| {
            f.display().to_string()
        });
    format!(
        "--height egm2008: no EGM2008 grid found (looked for {} in {}). Put PROJ's us_nga_egm08_25.tif (https://cdn.proj.org/us_nga_egm08_25.tif) in {user}, or GeographicLib's egm2008-1.pgm in /usr/local/share/GeographicLib/geoids, or give the file: --height geoid:FILE",
        EGM2008_FILES.join(", "),
        folders
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn proj_and_geographiclib_folders_in_order_and_the_finest_grid_first() {
        let env = |k: &str| match k {
            "PROJ_DATA" => Some("/a/proj:/b/proj".to_string()),
            "HOME" => Some("/home/u".to_string()),
            "GEOGRAPHICLIB_DATA" => Some("/g".to_string()),
            _ => None,
        };
        let f = folders(&env);
        let s: Vec<String> = f.iter().map(|p| p.display().to_string()).collect();
        assert_eq!(s[..3], ["/a/proj", "/b/proj", "/home/u/.local/share/proj"]);
        assert!(s.contains(&"/g/geoids".to_string()));
        assert!(s.contains(&"/usr/share/GeographicLib/geoids".to_string()));
        let dir = testkit::scratch_dir("geoid-find");
        let (a, b) = (dir.join("a"), dir.join("b"));
        std::fs::create_dir_all(&a).unwrap();
        std::fs::create_dir_all(&b).unwrap();
        std::fs::write(a.join("egm2008-5.pgm"), b"x").unwrap();
        std::fs::write(b.join("egm2008-5.pgm"), b"x").unwrap();
        std::fs::write(b.join("us_nga_egm08_25.tif"), b"x").unwrap();
        let got = first(&EGM2008_FILES, &[a.clone(), b.clone()]).unwrap();
        assert_eq!(got, a.join("egm2008-5.pgm"), "the first folder first");
        let got = first(&EGM2008_FILES, &[b.clone(), a.clone()]).unwrap();
        assert_eq!(got, b.join("us_nga_egm08_25.tif"), "2.5′ before 5′");
        assert!(first(&EGM2008_FILES, &[dir.join("none")]).is_none());
        let m = not_found(&f);
        assert!(
            m.contains("/home/u/.local/share/proj") && m.contains("geoid:FILE"),
            "{m}"
        );
    }
}
