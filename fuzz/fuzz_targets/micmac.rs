#![no_main]
//! MicMac XML: the input read as a calibration (and converted to a ppkat camera), as ground
//! points, as image measurements and as an orientation (the others small valid files), and as
//! OriConvert GNSS text.

use libfuzzer_sys::fuzz_target;
use ppkat_fuzz::{with_file, write_fixed};

const GROUND: &str = "<Global><DicoAppuisFlottant><OneAppuisDAF><Pt>10 20 30</Pt><NamePt>G1</NamePt><Incertitude>0.01 0.01 0.02</Incertitude></OneAppuisDAF></DicoAppuisFlottant></Global>";
const MEASURES: &str = "<Global><SetOfMesureAppuisFlottants><MesureAppuiFlottant1Im><NameIm>a.jpg</NameIm><OneMesureAF1I><NamePt>G1</NamePt><PtIm>100 200</PtIm></OneMesureAF1I></MesureAppuiFlottant1Im></SetOfMesureAppuisFlottants></Global>";
const CALIB: &str = "<ExportAPERO><CalibrationInternConique><KnownConv>eConvApero_DistM2C</KnownConv><PP>2000 1500</PP><F>3000</F><SzIm>4000 3000</SzIm><CalibDistortion><ModRad><CDist>2000 1500</CDist><CoeffDist>1e-9</CoeffDist></ModRad></CalibDistortion></CalibrationInternConique></ExportAPERO>";
/// The pixel size of every conversion below, micrometres.
const PIXEL_UM: f64 = 1.0;

fuzz_target!(|data: &[u8]| {
    use integration::import::micmac::{import, read_calibration, MicMacJob};
    with_file("fuzzed.xml", data, |p| {
        if let Ok(cal) = read_calibration(p) {
            // Converted as `import` converts the calibration it is given (the fixed one below).
            let _ = cal.to_camera(PIXEL_UM * 1e-6);
        }
        let dir = p.parent().expect("a folder").to_path_buf();
        let [g, m, c] = write_fixed(
            &dir,
            &[("g.xml", GROUND), ("m.xml", MEASURES), ("c.xml", CALIB)],
        );
        let job = |ground, measures, gnss| MicMacJob {
            ground,
            measures,
            calibration: Some(c.clone()),
            gnss,
            gnss_sigma: [0.05, 0.1],
            pixel_um: PIXEL_UM,
            sigma_px: 1.0,
            ..Default::default()
        };
        let _ = import(&job(p.to_path_buf(), m.clone(), None));
        let _ = import(&job(g.clone(), p.to_path_buf(), None));
        let gnss = Some((p.to_path_buf(), "#F=N X Y Z".to_string()));
        let _ = import(&job(g.clone(), m.clone(), gnss));
        // As an orientation file of a start-values folder.
        let ori = dir.join("ori");
        std::fs::create_dir_all(&ori).expect("temporary folder");
        std::fs::write(ori.join("Orientation-a.jpg.xml"), data).expect("temporary file");
        let _ = import(&MicMacJob {
            orientations: Some(ori),
            ..job(g, m, None)
        });
    });
});
