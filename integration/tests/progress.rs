//! What `spp` and `ppk` report as they go: every stage named (reading, the single-point
//! check of which receiver moves, each pass), counts that reach no more than each stage's
//! length, and outputs byte-identical to a run nobody watches.

use common::progress::{NoProgress, Progress};
use gnss::solution::PosFormat;
use integration::pipeline::{self, PpkJob, SppJob};
use integration::simulate;
use integration::vector::TrajectoryFormat;
use std::sync::Mutex;

/// Every call, in order: (stage, length, steps counted in it).
#[derive(Default)]
struct Record(Mutex<Vec<(String, u64, u64)>>);

impl Progress for Record {
    fn set_len(&self, stage: &str, len: u64) {
        self.0.lock().unwrap().push((stage.to_string(), len, 0));
    }
    fn inc(&self, n: u64) {
        if let Some(last) = self.0.lock().unwrap().last_mut() {
            last.2 += n;
        }
    }
    fn finish(&self) {}
}

use testkit::scratch_path as tmp;

fn stages(r: &Record) -> Vec<(String, u64, u64)> {
    r.0.lock().unwrap().clone()
}

#[test]
fn spp_and_ppk_name_their_stages_and_count_within_them() {
    let mut s = simulate::builtin("demo").unwrap();
    s.flight.strips = 1;
    s.flight.strip_length = 1000.0;
    let rep = simulate::run(&s, &tmp("flight")).unwrap();
    let epochs = rep.rover_stats.epochs as u64;

    let spp_job = |out: &str| SppJob {
        obs: rep.rover.clone(),
        obs_format: None,
        time_hint: None,
        nav: vec![rep.nav.clone()],
        sp3: vec![],
        clk: vec![],
        options: Default::default(),
        format: TrajectoryFormat::Pos(PosFormat::Xyz),
        heights: Default::default(),
        out: tmp(out),
    };
    let rec = Record::default();
    pipeline::spp(&spp_job("watched.pos"), &rec).unwrap();
    pipeline::spp(&spp_job("unwatched.pos"), &NoProgress).unwrap();
    let st = stages(&rec);
    assert_eq!(st[0].0, "reading the observations");
    assert_eq!(st[1].0, "single point");
    assert_eq!(st[1].1, epochs);
    assert!(st[1].2 <= epochs && st[1].2 + 256 > epochs, "{st:?}");
    let bytes = |n: &str| std::fs::read(tmp(n)).unwrap();
    assert_eq!(bytes("watched.pos"), bytes("unwatched.pos"));

    let ppk_job = |out: &str| PpkJob {
        rover: rep.rover.clone(),
        base: rep.base.clone(),
        obs_format: None,
        time_hint: None,
        nav: vec![rep.nav.clone()],
        sp3: vec![],
        clk: vec![],
        base_position: gnss::ppk::BasePosition::Header,
        base_from_ppp: false,
        options: Default::default(),
        format: TrajectoryFormat::Pos(PosFormat::Xyz),
        heights: Default::default(),
        out: tmp(out),
        report: None,
    };
    let rec = Record::default();
    pipeline::ppk(&ppk_job("watched-ppk.pos"), &rec).unwrap();
    pipeline::ppk(&ppk_job("unwatched-ppk.pos"), &NoProgress).unwrap();
    let st = stages(&rec);
    let names: Vec<&str> = st.iter().map(|s| s.0.as_str()).collect();
    assert_eq!(names[0], "reading rover and base");
    assert!(
        names.contains(&"checking which receiver moves (single point)"),
        "{names:?}"
    );
    let passes: Vec<_> = st.iter().filter(|s| s.1 > 0).collect();
    assert!(!passes.is_empty(), "{st:?}");
    for (stage, len, done) in passes {
        assert!(done <= len, "{stage}: {done} of {len}");
        assert!(*done * 10 >= *len * 9, "{stage} counted {done} of {len}");
    }
    assert_eq!(bytes("watched-ppk.pos"), bytes("unwatched-ppk.pos"));
}
