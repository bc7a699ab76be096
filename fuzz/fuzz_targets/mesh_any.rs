#![no_main]
//! Fuzzes loading and meshing together (`kdcontour::io::probe::mesh_any`): the
//! first byte picks a loader, whatever loads is meshed at res 8 and checked.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Some(report) = kdcontour::io::probe::mesh_any(data) {
        // Every vertex is finite and the field is finite there.
        assert!(
            report.max_error.is_finite() && report.mean_error.is_finite(),
            "{report:?}"
        );
    }
});
