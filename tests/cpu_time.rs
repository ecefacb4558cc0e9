//! `wavepath converge` reports CPU time next to wall time (what a render
//! would take on idle cores); this checks the CPU time it reads.

use std::io::Read;

/// Process CPU time counts user and system time, in seconds. The oracle
/// is the test thread's own share, read from `/proc/thread-self/stat`:
/// spinning until it shows 0.2 s of user time and reading `/dev/zero` until
/// it shows 0.2 s of system time must add as much to the process's count,
/// within a few 10 ms ticks. This file holds one test so that no other test
/// thread adds CPU time of its own while it runs.
#[test]
fn process_cpu_time_counts_user_and_system_time() {
    let thread_times = || -> Option<(f64, f64)> {
        let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
        let after_name = stat.rsplit_once(')')?.1;
        let fields: Vec<&str> = after_name.split_whitespace().collect();
        // After "pid (comm)": state is field 3, utime 14, stime 15.
        let tick = |i: usize| fields.get(i - 3)?.parse::<f64>().ok().map(|t| t / 100.0);
        Some((tick(14)?, tick(15)?))
    };
    let Some((user0, system0)) = thread_times() else {
        eprintln!("skipped: no /proc/thread-self/stat on this system");
        return;
    };
    // Where a thread's times can be read, so can the process's.
    let before = wavepath::cli::converge::process_cpu_seconds().expect("process CPU time");
    let wall = std::time::Instant::now();
    let stuck = || wall.elapsed().as_secs() > 30;
    let mut spins = 0u64;
    while thread_times().unwrap().0 - user0 < 0.2 && !stuck() {
        for _ in 0..100_000 {
            spins = std::hint::black_box(spins.wrapping_mul(31).wrapping_add(7));
        }
    }
    let mut zero = std::fs::File::open("/dev/zero").unwrap();
    let mut buffer = vec![0u8; 1 << 20];
    while thread_times().unwrap().1 - system0 < 0.2 && !stuck() {
        zero.read_exact(&mut buffer).unwrap();
    }
    if stuck() {
        eprintln!("skipped: this system does not count the thread's CPU time in /proc");
        return;
    }
    let used = wavepath::cli::converge::process_cpu_seconds().unwrap() - before;
    let (user1, system1) = thread_times().unwrap();
    let own = (user1 - user0) + (system1 - system0);
    assert!(own >= 0.39, "{own} s");
    assert!(
        (used - own).abs() <= 0.05,
        "process {used} s, this thread {own} s"
    );
}
