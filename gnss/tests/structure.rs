//! No function over 120 lines, and no two files of `gnss` import each other, directly or around a
//! circle (see `testkit::imports`); and the check finds a circle planted on purpose.

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
    // Broken, the circle is gone; a macro's `$crate::…` is resolved where it is used.
    write(
        "b.rs",
        "pub struct B;\nmacro_rules! m { () => { $crate::a::X(B) }; }\n",
    );
    assert!(testkit::imports::import_circles(&src).is_empty());
}

#[test]
fn no_function_over_120_lines_in_gnss() {
    testkit::imports::assert_no_long_functions(env!("CARGO_MANIFEST_DIR"), 120);
}

#[test]
fn a_long_function_is_found() {
    let src = testkit::scratch_dir("long/src");
    let body = |n: usize| "    let _ = 1;\n".repeat(n);
    let text = format!(
        "fn short() {{\n{}}}\n\nfn long(x: u8) -> u8 {{\n{}    x\n}}\n\n/// fn in a comment {{\nfn decl();\n",
        body(100),
        body(125)
    );
    std::fs::write(src.join("lib.rs"), text).unwrap();
    let long = testkit::imports::long_functions(&src, 120);
    assert_eq!(long, vec![("lib.rs".to_string(), "long".to_string(), 128)]);
}
