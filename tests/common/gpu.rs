//! The GPU adapter the tests share: one per test binary. Where none exists the test is skipped
//! with a note, unless `RAIN_COMPOSITE_REQUIRE_GPU` is set (CI): then it fails.

use std::sync::{Arc, OnceLock};

use rain_composite::gpu::{AdapterRequest, GpuContext};

/// The shared adapter, or `None` (skip) where there is none and none is required.
pub fn gpu() -> Option<Arc<GpuContext>> {
    static CTX: OnceLock<Option<Arc<GpuContext>>> = OnceLock::new();
    CTX.get_or_init(|| match GpuContext::new(&AdapterRequest::default()) {
        Ok(c) => Some(Arc::new(c)),
        Err(e) => {
            assert!(
                std::env::var_os("RAIN_COMPOSITE_REQUIRE_GPU").is_none(),
                "no GPU adapter: {e}"
            );
            eprintln!("skipping GPU test: {e}");
            None
        }
    })
    .clone()
}
