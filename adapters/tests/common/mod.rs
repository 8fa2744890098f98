//! Waits shared by the Dex3 USB loop tests: poll a condition against a deadline (never a
//! fixed sleep as synchronisation).

#![allow(dead_code)]

use std::time::{Duration, Instant};

use handgate_adapters::dex3::usb::Dex3UsbHandle;
use handgate_adapters::dex3::Dex3Measurement;

/// Polls `f` every 2 ms until it returns Some; panics naming `what` after `deadline`.
pub fn wait_for<T>(deadline: Duration, what: &str, mut f: impl FnMut() -> Option<T>) -> T {
    let end = Instant::now() + deadline;
    loop {
        if let Some(v) = f() {
            return v;
        }
        assert!(Instant::now() < end, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Waits until the loop's latest measurement satisfies `f`, and returns it.
pub fn wait_meas(
    deadline: Duration,
    h: &Dex3UsbHandle,
    what: &str,
    f: impl Fn(&Dex3Measurement) -> bool,
) -> Dex3Measurement {
    wait_for(deadline, what, || {
        let m = h.latest();
        f(&m).then_some(m)
    })
}
