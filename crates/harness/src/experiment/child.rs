//! A reproduce run as a child process that ends with reproduce: SIGINT, SIGTERM and SIGHUP
//! to reproduce end the run (its process group: SIGTERM, SIGKILL after a grace period), wait
//! for it, and are reported, so no orphaned `run` keeps writing into the runs folder. On
//! Linux a run also ends when reproduce dies without a word (SIGKILL).

use std::process::{Command, ExitStatus};
use std::sync::atomic::{AtomicI32, Ordering};
use std::time::{Duration, Instant};

static SIGNAL: AtomicI32 = AtomicI32::new(0);

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    SIGNAL.store(sig, Ordering::SeqCst);
}

/// Catch SIGINT, SIGTERM and SIGHUP from here on: [`received`] says which came.
pub fn catch_signals() {
    #[cfg(unix)]
    for s in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP] {
        // SAFETY: the handler only stores into an atomic, which is async-signal-safe.
        unsafe {
            libc::signal(s, on_signal as *const () as libc::sighandler_t);
        }
    }
}

/// The signal received since [`catch_signals`], if any.
pub fn received() -> Option<i32> {
    match SIGNAL.load(Ordering::SeqCst) {
        0 => None,
        s => Some(s),
    }
}

/// A signal's name (`SIGTERM`).
pub fn signal_name(s: i32) -> String {
    match s {
        2 => "SIGINT".into(),
        15 => "SIGTERM".into(),
        1 => "SIGHUP".into(),
        9 => "SIGKILL".into(),
        s => format!("signal {s}"),
    }
}

/// How a process ended, in words: `exit status 1`, `killed by signal 15`.
pub fn ended(st: &ExitStatus) -> String {
    if let Some(c) = st.code() {
        return format!("exit status {c}");
    }
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if let Some(s) = st.signal() {
            return format!("killed by signal {s}");
        }
    }
    "ended without an exit status".into()
}

/// How long a run has to end after SIGTERM before it is killed.
const GRACE: Duration = Duration::from_secs(5);

/// Run `cmd` in its own process group to its end, or until a signal reaches reproduce: then
/// end the group, wait for it, and return the signal beside the run's status.
pub fn run(cmd: &mut Command) -> std::io::Result<(ExitStatus, Option<i32>)> {
    run_until(cmd, None).map(|(st, sig, _)| (st, sig))
}

/// [`run`] with a deadline: a child still running at `deadline` is ended as on a signal
/// (SIGTERM to its group, SIGKILL after [`GRACE`]), and the third value says so.
pub fn run_until(
    cmd: &mut Command,
    deadline: Option<Instant>,
) -> std::io::Result<(ExitStatus, Option<i32>, bool)> {
    #[cfg(unix)]
    {
        use std::os::unix::process::CommandExt;
        cmd.process_group(0);
        #[cfg(target_os = "linux")]
        // SAFETY: prctl is async-signal-safe; nothing else runs between fork and exec.
        unsafe {
            cmd.pre_exec(|| {
                libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
                Ok(())
            });
        }
    }
    let mut child = cmd.spawn()?;
    loop {
        if let Some(st) = child.try_wait()? {
            return Ok((st, received(), false));
        }
        if let Some(sig) = received() {
            end(&mut child);
            return Ok((child.wait()?, Some(sig), false));
        }
        if deadline.is_some_and(|d| Instant::now() >= d) {
            end(&mut child);
            return Ok((child.wait()?, None, true));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// SIGTERM to the child's process group, SIGKILL after [`GRACE`].
fn end(child: &mut std::process::Child) {
    #[cfg(unix)]
    {
        let group = -(child.id() as libc::pid_t);
        // SAFETY: kill(2) on the child's own process group.
        unsafe { libc::kill(group, libc::SIGTERM) };
        let t = Instant::now();
        while t.elapsed() < GRACE {
            if matches!(child.try_wait(), Ok(Some(_))) {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        // SAFETY: as above.
        unsafe { libc::kill(group, libc::SIGKILL) };
    }
    let _ = child.kill();
}
