//! No two files of the command-line crate import each other, directly or around a circle
//! (see `testkit::imports`).

#[test]
fn no_import_circle_between_the_files_of_the_cli() {
    testkit::imports::assert_no_import_circles(env!("CARGO_MANIFEST_DIR"));
}
