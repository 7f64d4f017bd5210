//! The feature cache's key (`src/cache.rs`) holds a hash of the code extraction runs — the
//! feature and sampling code of `photo`, this crate's decoder — and of the lock file that
//! fixes the SIFT and JPEG crates' versions: features made by other code are never read back
//! as this code's, whatever folder holds them.

use std::path::Path;

/// The files whose bytes the hash covers, from this crate's folder.
const SOURCES: [&str; 4] = [
    "../../photo/src/features/mod.rs",
    "../../photo/src/features/sampling.rs",
    "src/decode.rs",
    "../../Cargo.lock",
];

fn main() {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for f in SOURCES {
        println!("cargo:rerun-if-changed={f}");
        for b in std::fs::read(here.join(f)).unwrap_or_default() {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    let out = Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"))
        .join("extraction_source.rs");
    std::fs::write(out, format!("{h}u64\n")).expect("write the extraction source hash");
}
