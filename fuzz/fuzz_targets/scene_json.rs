#![no_main]
//! Fuzzes the `scene_json` loader (`kdcontour::io::probe::load`): any input must load or
//! be refused with a message, never panic, hang or exhaust memory.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Err(message) = kdcontour::io::probe::load("scene_json", data) {
        assert!(!message.is_empty(), "a refusal must say why");
    }
});
