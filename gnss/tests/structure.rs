//! No two files of `gnss` import each other, directly or around a circle (see
//! `testkit::imports`); and the check finds a circle planted on purpose.

#[test]
fn no_import_circle_between_the_files_of_gnss() {
    testkit::imports::assert_no_import_circles(env!("CARGO_MANIFEST_DIR"));
}

#[test]
fn a_planted_circle_is_found() {
    let src = testkit::scratch_dir("planted/src");
    let write = |name: &str, text: &str| {
        let p = src.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    write("lib.rs", "pub mod a;\npub mod b;\npub mod c;\nmod tidy;\n");
    write("a/mod.rs", "mod x;\npub use x::X;\n");
    write("a/x.rs", "use crate::b::B;\npub struct X(B);\n");
    // b reaches a through an expression path, split over lines, not a `use`.
    write(
        "b.rs",
        "pub struct B;\nfn f() { let _ = crate::a\n    ::X(B); }\n",
    );
    // Neither a doc comment, a string nor an inline test module makes an edge.
    write(
        "c.rs",
        "/// See crate::b::B.\npub fn g() -> &'static str { \"crate::b::B {\" }\n#[cfg(test)]\nmod tests { use super::*; }\n",
    );
    write(
        "tidy.rs",
        "use crate::c::g;\nuse super::c::{self as cc, g as h};\n",
    );
    assert_eq!(
        testkit::imports::import_circles(&src),
        vec![vec!["a/mod.rs".to_string(), "a/x.rs".into(), "b.rs".into()]]
    );
    // Broken, the circle is gone.
    write("b.rs", "pub struct B;\n");
    assert!(testkit::imports::import_circles(&src).is_empty());
}
