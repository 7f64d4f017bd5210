//! No function over 120 lines, and no two files of `common` import each other, directly or
//! around a circle (see `testkit::imports`).

#[test]
fn no_import_circle_between_the_files_of_common() {
    testkit::imports::assert_no_import_circles(env!("CARGO_MANIFEST_DIR"));
}

#[test]
fn no_function_over_120_lines_in_common() {
    testkit::imports::assert_no_long_functions(env!("CARGO_MANIFEST_DIR"), 120);
}
