//! No heap allocation per epoch with the static back-end: a counting global allocator
//! over 10,000 INS epochs (mechanization, covariance propagation, GNSS position+velocity
//! updates every 20 epochs) after start-up.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use estimator::adaptive::{AnyStrategy, STRATEGY_NAMES};
use estimator::estimator_core::{FixedNoise, NoObserver, NoiseStrategy};
use estimator::ins_gnss::{InsModel, Navigator};
use ins_gnss::config::{Config, ConfigKind};
use ins_gnss_sim::scenarios;

mod simulated_drive;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Heap allocations over 10,000 INS epochs with `strategy` after 100 epochs of start-up,
/// and the number of updates in them.
fn allocations_over_10000_epochs<A: NoiseStrategy>(strategy: A) -> (usize, usize) {
    // one measurement at a time (the tests of this file run on parallel threads, and the
    // count is the process's)
    static ONE_AT_A_TIME: Mutex<()> = Mutex::new(());
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let data = simulated_drive::drive(8, 200.0, 1);
    assert!(data.imu.len() >= 10_100);
    let (init, cfg) = simulated_drive::start_at_truth(&data);
    let mut nav =
        Navigator::new(&init, InsModel::wgs84(scenarios::mems_imu().noise), strategy, cfg).unwrap();
    let mut out = Vec::with_capacity(16);
    let mut observer = NoObserver;
    let mut updates = 0;
    let mut replay = data.replay();
    let mut step = |nav: &mut Navigator<A>, count: bool| {
        let (s, gnss) = replay.next().expect("enough samples");
        out.clear();
        nav.process_into(s, gnss, &mut observer, &mut out).unwrap();
        if count {
            updates += out.len();
        }
    };
    // Start-up: the first 100 epochs (first GNSS updates, feature detection caches, the
    // strategy's per-stream state).
    for _ in 0..100 {
        step(&mut nav, false);
    }
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    for _ in 100..10_100 {
        step(&mut nav, true);
    }
    (ALLOCATIONS.load(Ordering::Relaxed) - before, updates)
}

#[test]
fn ins_epochs_do_not_allocate() {
    let (allocations, updates) = allocations_over_10000_epochs(FixedNoise);
    assert_eq!(allocations, 0, "heap allocations during 10,000 epochs");
    // The run did real work: GNSS updates happened.
    assert!(updates > 400);
}

/// The program's strategies (`ins-gnss run --strategy NAME`, each on every stream behind
/// the gross-error gate that adapts before it refuses; the default is `fixed`) do not
/// allocate either: the filter keeps the copy of the strategy it restores on a failed
/// update and refills it in place, window vectors included.
#[test]
fn epochs_with_every_strategy_of_the_program_do_not_allocate() {
    let text = r#"
        [data]
        imu = "IMU.txt"
        gnss = "GNSS.txt"
        imu_rate = 200.0

        [imu_noise]
        arw = [0.3, 0.3, 0.3]
        vrw = [0.029, 0.029, 0.029]
        gyro_bias_std = [6.5, 6.5, 6.5]
        accel_bias_std = [98.0665, 98.0665, 98.0665]
        corr_time = 0.027778
    "#;
    let config = Config::parse(text, ConfigKind::Toml, Path::new(".")).unwrap();
    assert_eq!(config.filter.strategy, "fixed");
    for name in STRATEGY_NAMES {
        let strategy = config.strategy(name.parse::<AnyStrategy>().unwrap()).unwrap();
        let (allocations, updates) = allocations_over_10000_epochs(strategy);
        assert_eq!(allocations, 0, "{name}: heap allocations during 10,000 epochs");
        assert!(updates > 400, "{name}: {updates} updates");
    }
}
