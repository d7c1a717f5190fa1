//! `fluidswarm-agent --spec JSON`: one SPH particle as one OS process (docs/protocol.md).
//!
//! Exit codes: 0 done, 2 bad spec, 3 fell behind, 4 stopped (ctl/stop, SIGTERM, SIGINT), 5 no start.

use std::sync::atomic::{AtomicBool, Ordering};

use fluidswarm_agent::agent::EXIT_STOPPED;
use fluidswarm_agent::route::CommandFollower;
use fluidswarm_agent::session::{client_config, env_credentials};
use fluidswarm_agent::shell::{self, STOP};
use fluidswarm_agent::spec::{unhex, AgentSpec};
use zenoh::Wait;

/// Until the session is open the process has nothing to report: a signal then ends it at once. Inside
/// `zenoh::open` (which retries its router for up to 2 minutes) no flag would be looked at.
static SESSION_OPEN: AtomicBool = AtomicBool::new(false);

extern "C" fn on_signal(_: libc::c_int) {
    if !SESSION_OPEN.load(Ordering::SeqCst) {
        // SAFETY: _exit is async-signal-safe.
        unsafe { libc::_exit(EXIT_STOPPED) };
    }
    STOP.store(true, Ordering::SeqCst);
    // A last resort if closing hangs (the router died with the launcher): leave 5 s later regardless.
    // SAFETY: alarm is async-signal-safe; SIGALRM's handler only calls _exit.
    unsafe { libc::alarm(5) };
}

extern "C" fn on_alarm(_: libc::c_int) {
    // SAFETY: _exit is async-signal-safe.
    unsafe { libc::_exit(EXIT_STOPPED) };
}

fn install_signals() {
    // SAFETY: installing plain C handlers that only touch atomics and call async-signal-safe functions.
    unsafe {
        libc::signal(libc::SIGTERM, on_signal as *const () as usize);
        libc::signal(libc::SIGINT, on_signal as *const () as usize);
        libc::signal(libc::SIGALRM, on_alarm as *const () as usize);
    }
    // The launcher's death stops us (it spawns without a fork hook, so this is the only place it is asked
    // for). The kernel ties it to the spawning *thread*: the launcher spawns every agent from one thread that
    // outlives them (swarmhost/supervisor.py).
    // SAFETY: prctl/getppid/_exit with plain integer arguments.
    unsafe {
        let parent = libc::getppid();
        libc::prctl(libc::PR_SET_PDEATHSIG, libc::SIGTERM);
        if libc::getppid() != parent || parent == 1 {
            libc::_exit(EXIT_STOPPED); // the parent died before the line above took effect
        }
    }
}

fn fail(msg: &str) -> ! {
    eprintln!("fluidswarm agent: error: {msg}");
    std::process::exit(2)
}

/// Zenoh's runtimes (app, rx, tx, acc, net) each start threads. The agent runs one worker, its receiving
/// thread, and hands every other runtime over to it: the callbacks run the agent's core on that worker
/// (shell.rs) and its state put wakes the link's transmit task on the same worker, which tokio then runs
/// from the worker's own slot with no other thread woken (tokio's multi-thread scheduler: a task woken from
/// one of its workers goes to that worker's LIFO slot; from any other thread it is queued and a parked worker
/// unparked). Measured on the bare exchange at N = 300: 6.7 -> 2.0 context switches and 192 -> 127 us of agent
/// CPU per agent-step (docs/benchmarks/realtime.md, "One wake-up per step"). Before: one receiving worker and
/// one app worker (1.23x the steps/s of zenoh's default layout then, docs/benchmarks/native.md). zenoh reads its
/// layout only from ZENOH_RUNTIME, so it is set here for this process alone (in the launcher's environment it
/// would also reach its router, which needs its threads).
fn choose_runtime() {
    let layout = "(rx:(worker_threads:1),tx:(handover:rx),app:(handover:rx),net:(handover:rx),acc:(handover:rx))";
    // SAFETY: called first thing in main, before any other thread exists.
    unsafe { std::env::set_var("ZENOH_RUNTIME", layout) };
}

fn main() {
    // One program for agent and router (one thin-LTO link of zenoh instead of two, issue 52): started as
    // fluidswarm-router (argv[0]; src/router_main.rs execs this program so), it is the router.
    let argv0 = std::env::args_os().next().unwrap_or_default();
    if std::path::Path::new(&argv0).file_name().is_some_and(|n| n == "fluidswarm-router") {
        // its name in ps and /proc/PID/comm (tests/test_faults.py finds the router so), not the file's
        // SAFETY: PR_SET_NAME with a NUL-terminated name of at most 16 bytes.
        unsafe { libc::prctl(libc::PR_SET_NAME, c"fluidswarm-rout".as_ptr()) };
        return fluidswarm_agent::router_program::main();
    }
    fluidswarm_agent::abort_on_panic();
    choose_runtime();
    install_signals();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let text = match args.as_slice() {
        [flag, text] if flag == "--spec" => text.clone(),
        [flag] if flag.starts_with("--spec=") => flag["--spec=".len()..].to_string(),
        _ => fail("usage: fluidswarm-agent --spec JSON (the agent's start-up parameters, agent/protocol/spec.py)"),
    };
    let spec = AgentSpec::from_json(&text).unwrap_or_else(|e| fail(&e));
    let secret_hex = if spec.secret.is_empty() {
        std::env::var("FLUIDSWARM_SECRET").unwrap_or_default()
    } else {
        spec.secret.clone()
    };
    let controller = if secret_hex.is_empty() {
        None
    } else {
        let secret = unhex(&secret_hex).unwrap_or_else(|| fail("FLUIDSWARM_SECRET: must be hex"));
        Some(CommandFollower::new(secret, spec.id, spec.control))
    };
    let (user, password) = env_credentials();
    let config = client_config(&spec.connect, &user, &password).unwrap_or_else(|e| fail(&format!("zenoh config: {e}")));
    let session = match zenoh::open(config).wait() {
        Ok(s) => s,
        Err(e) => {
            eprintln!("fluidswarm agent {}: cannot reach the router {:?}: {e}", spec.id, spec.connect);
            std::process::exit(EXIT_STOPPED)
        }
    };
    SESSION_OPEN.store(true, Ordering::SeqCst);
    if STOP.load(Ordering::SeqCst) {
        std::process::exit(EXIT_STOPPED);
    }
    let code = shell::run(spec, controller, session.clone());
    let _ = session.close().wait();
    std::process::exit(code)
}
