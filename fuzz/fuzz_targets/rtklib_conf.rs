#![no_main]
//! RTKLIB configuration files (`ppkat ppk --rtklib-conf`): every option mapped to a flag or
//! listed as ignored, never a panic, whatever the text.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let m = integration::rtklib_conf::map(&text, std::path::Path::new("conf"));
    let _ = m.notes(std::path::Path::new("x.conf"));
    for s in &m.settings {
        assert!(!s.flag.is_empty() && !s.values.is_empty());
    }
});
