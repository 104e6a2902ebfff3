//! Opening stores never silences panics elsewhere: the process's panic hook stays the one
//! installed, on every thread, while stores open (and fail to open) in parallel. Its own
//! test binary: it installs a process-wide hook.

use multistep_controller::store::{Store, DB_FILE};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

#[test]
fn opening_stores_on_many_threads_keeps_every_panic_message() {
    let seen = Arc::new(Mutex::new(Vec::<String>::new()));
    {
        let seen = seen.clone();
        std::panic::set_hook(Box::new(move |info| {
            let msg = info
                .payload()
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| info.payload().downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            seen.lock().unwrap_or_else(|p| p.into_inner()).push(msg);
        }));
    }
    let root = tempfile::tempdir().unwrap();
    let done = Arc::new(AtomicBool::new(false));
    let openers: Vec<_> = (0..4)
        .map(|t| {
            let dir = root.path().join(format!("t{t}"));
            std::thread::spawn(move || {
                for n in 0..40 {
                    let d = dir.join(n.to_string());
                    if n % 2 == 0 {
                        // a board database, created and opened
                        drop(Store::open(&d).unwrap());
                    } else {
                        // a damaged one, refused
                        std::fs::create_dir_all(&d).unwrap();
                        std::fs::write(d.join(DB_FILE), vec![0x5a; 4096]).unwrap();
                        assert!(Store::open(&d).is_err());
                    }
                }
            })
        })
        .collect();
    let panicker = {
        let done = done.clone();
        std::thread::spawn(move || {
            let mut n = 0;
            while !done.load(Ordering::Relaxed) {
                let r = std::panic::catch_unwind(|| panic!("deliberate panic {n}"));
                assert!(r.is_err());
                n += 1;
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
            n
        })
    };
    for o in openers {
        o.join().unwrap();
    }
    done.store(true, Ordering::Relaxed);
    let sent = panicker.join().unwrap();
    // one more, after every store is open or refused
    let _ = std::panic::catch_unwind(|| panic!("deliberate panic at the end"));
    let _ = std::panic::take_hook();
    let seen = seen.lock().unwrap().clone();
    let deliberate: Vec<&String> = seen
        .iter()
        .filter(|m| m.starts_with("deliberate"))
        .collect();
    assert!(sent > 0);
    assert_eq!(
        deliberate.len(),
        sent + 1,
        "{} of {} panic messages reached the hook",
        deliberate.len(),
        sent + 1
    );
    // What the database library says about a damaged file is the store's error, not a
    // panic message.
    assert_eq!(seen.len(), deliberate.len(), "{seen:?}");
}
