//! The textured block (`simulate --builtin textured-block`): photos of the stated size, the
//! truth's pixel ↔ ground maps against each other and against the exact measurements, the
//! renderer's pixel convention (a disc's centroid is the projection of its centre), and the
//! same bytes for the same seed whatever the thread count. The adjustment of the project is
//! in the CLI tests (`tests/cli/adjust.rs`).

use gnss::frame::Enu;
use integration::simulate::rng::Rng;
use integration::simulate::textured::{
    pixel_ray, render, textured_block, Extent, RenderOptions, Terrain, Texture, TexturedSpec, Truth,
};
use nalgebra::{Vector2, Vector3};
use photo::camera::Pose;
use photo::rotation::Angles;
use std::path::{Path, PathBuf};

use testkit::scratch_path as tmp;

/// The rows of a CSV file (comments and header skipped), split at commas.
fn rows(path: &Path) -> Vec<Vec<String>> {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

/// The reduced block, simulated once per test binary.
fn reduced() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tmp("reduced");
        let rep = textured_block(&TexturedSpec::reduced(), &dir).unwrap();
        eprintln!(
            "reduced block: {} images rendered in {:.2} s",
            rep.images, rep.render_seconds
        );
        dir
    })
}

#[test]
fn every_image_has_a_photo_of_the_stated_size() {
    let dir = reduced();
    let spec = TexturedSpec::reduced();
    let images = rows(&dir.join("images.csv"));
    assert_eq!(images.len(), spec.strips * spec.per_strip);
    for im in &images {
        let p = dir.join("photos").join(format!("{}.png", im[0]));
        // The PNG decoder alone: `image::open` would build every format's into this test.
        let file = std::io::BufReader::new(std::fs::File::open(&p).unwrap());
        let png = image::codecs::png::PngDecoder::new(file).unwrap();
        let img = image::DynamicImage::from_decoder(png).unwrap();
        assert_eq!(img.color(), image::ColorType::L8, "{}", p.display());
        assert_eq!((img.width(), img.height()), (400, 300));
        // Textured: a wide spread of grey levels.
        let g = img.to_luma8();
        let (lo, hi) = g
            .pixels()
            .fold((255, 0), |(a, b), p| (a.min(p[0]), b.max(p[0])));
        assert!(hi - lo > 150, "{}: {lo}..{hi}", p.display());
    }
    let n = std::fs::read_dir(dir.join("photos")).unwrap().count();
    assert_eq!(n, images.len());
    let camera = std::fs::read_to_string(dir.join("camera.toml")).unwrap();
    let project = std::fs::read_to_string(dir.join("project.toml")).unwrap();
    assert!(
        project.contains(&camera),
        "project.toml holds camera.toml's table"
    );
}

/// pixel → ground → pixel to 1e-6 px in every image, and every exact measurement of
/// `image_observations.csv` is where the truth puts its ground point.
#[test]
fn ground_of_and_project_invert_each_other_and_fit_the_measurements() {
    let dir = reduced();
    let truth = Truth::load(dir).unwrap();
    assert_eq!(truth.poses.len(), 8);
    let (w, h) = (truth.camera.width_px as f64, truth.camera.height_px as f64);
    let mut worst: f64 = 0.0;
    for (id, _) in &truth.poses {
        for a in 0..=10 {
            for b in 0..=10 {
                let px = Vector2::new(
                    0.5 + (w - 1.0) * a as f64 / 10.0,
                    0.5 + (h - 1.0) * b as f64 / 10.0,
                );
                let g = truth.ground_of(id, px).expect("a ground point");
                let back = truth.project(id, &g).expect("inside");
                worst = worst.max((back - px).norm());
            }
        }
    }
    assert!(worst < 1e-6, "round trip {worst} px");
    assert!(truth.ground_of("nosuch", Vector2::new(1.0, 1.0)).is_none());
    assert!(truth.ground_of("101", Vector2::new(-0.5, 1.0)).is_none());
    // The measurements against the true points (written to 1e-6 px).
    let points: std::collections::HashMap<String, Enu> = rows(&dir.join("truth_points.csv"))
        .into_iter()
        .map(|r| {
            let v: Vec<f64> = r[2..5].iter().map(|x| x.parse().unwrap()).collect();
            (r[0].clone(), Enu(Vector3::new(v[0], v[1], v[2])))
        })
        .collect();
    let meas = rows(&dir.join("image_observations.csv"));
    assert!(meas.len() > 100, "{} measurements", meas.len());
    let mut worst: f64 = 0.0;
    for m in &meas {
        let px = Vector2::new(m[2].parse().unwrap(), m[3].parse().unwrap());
        let p = truth.project(&m[0], &points[&m[1]]).expect("seen");
        worst = worst.max((p - px).norm());
        // The truth's ground point under the measurement is the point itself (on the terrain).
        let g = truth.ground_of(&m[0], px).unwrap();
        assert!((g.0 - points[&m[1]].0).norm() < 2e-4, "{m:?}");
    }
    assert!(worst < 2e-6, "measurements {worst} px");
}

/// White discs on black, seen through the distorted camera from a tilted pose over the
/// block's terrain: the intensity centroid of each disc lies within 0.05 px of the projection
/// of its centre — the renderer's pixels are those of `photo::camera` (origin at the
/// top-left corner of the top-left pixel, centre of pixel (i, j) at (i + ½, j + ½)).
#[test]
fn a_disc_is_rendered_where_the_camera_projects_its_centre() {
    let spec = TexturedSpec::builtin();
    let cam = spec.camera().unwrap();
    let extent = Extent {
        xmin: -60.0,
        xmax: 60.0,
        ymin: -60.0,
        ymax: 60.0,
    };
    let terrain = Terrain::generate(spec.seed, &extent);
    let pose = Pose {
        r: Angles::OmegaPhiKappa {
            omega: 1.7f64.to_radians(),
            phi: -1.3f64.to_radians(),
            kappa: 0.6f64.to_radians(),
        }
        .matrix(),
        centre: Vector3::new(3.0, -2.0, 100.0),
    };
    // Disc centres: where the rays of chosen pixels meet the terrain (centre, corners).
    let (w, h) = (cam.width_px as f64, cam.height_px as f64);
    let aims = [
        (0.5, 0.5),
        (0.1, 0.1),
        (0.9, 0.12),
        (0.13, 0.88),
        (0.92, 0.9),
        (0.3, 0.6),
    ];
    let centres: Vec<Vector3<f64>> = aims
        .iter()
        .map(|(a, b)| {
            let ray = pixel_ray(&cam, &pose, Vector2::new(a * w + 0.31, b * h + 0.77));
            terrain.intersect(&ray, 0.0, 1e-9).unwrap()
        })
        .collect();
    let xy: Vec<Vector2<f64>> = centres.iter().map(|c| c.xy()).collect();
    let texture = Texture::discs(&xy, 0.4);
    let opts = RenderOptions {
        noise_grey: 0.0,
        ..RenderOptions::default()
    };
    let img = render::render(&terrain, &texture, &cam, &pose, &opts, &mut Rng::new(1));
    for c in &centres {
        // The disc's centre on the terrain (its rim lies on the terrain too, ~8 px radius).
        let c = Vector3::new(c.x, c.y, terrain.height(c.xy()));
        let p = cam.image_to_pixel(cam.project(&pose, &c).unwrap());
        let (mut sum, mut sx, mut sy) = (0.0, 0.0, 0.0);
        let (i0, j0) = (p.x as usize - 20, p.y as usize - 20);
        for j in j0..j0 + 41 {
            for i in i0..i0 + 41 {
                let v = img.at(i, j) as f64;
                sum += v;
                sx += v * (i as f64 + 0.5);
                sy += v * (j as f64 + 0.5);
            }
        }
        let centroid = Vector2::new(sx / sum, sy / sum);
        let d = (centroid - p).norm();
        eprintln!(
            "disc at ({:.3}, {:.3}): centroid off by ({:.4}, {:.4}) px",
            p.x,
            p.y,
            centroid.x - p.x,
            centroid.y - p.y
        );
        assert!(sum > 255.0 * 100.0, "the disc is in the image");
        assert!(d < 0.05, "centroid {centroid} vs projection {p}: {d} px");
    }
}

/// The same seed gives the same bytes, on one thread as on several.
#[test]
fn the_same_seed_gives_the_same_photos_on_any_number_of_threads() {
    let dir = reduced();
    let again = tmp("again");
    rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| textured_block(&TexturedSpec::reduced(), &again))
        .unwrap();
    let mut files = 0;
    for sub in ["", "photos"] {
        for e in std::fs::read_dir(dir.join(sub)).unwrap() {
            let e = e.unwrap();
            if e.file_type().unwrap().is_file() {
                let a = std::fs::read(e.path()).unwrap();
                let b = std::fs::read(again.join(sub).join(e.file_name())).unwrap();
                assert!(a == b, "{} differs", e.path().display());
                files += 1;
            }
        }
    }
    assert!(files >= 8 + 10, "{files} files compared");
}
