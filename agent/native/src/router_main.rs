//! `fluidswarm-router RUN`: a run's embedded router at access level `acl`, the state relay on its own session
//! (swarmhost/router_process.py starts it; docs/protocol.md, docs/security.md).
//!
//! Its Zenoh configuration (listen endpoints, the users file, the access-control rules) is a JSON file named
//! by FLUIDSWARM_ROUTER_CONFIG, written privately by the launcher: never on the command line. The launcher
//! talks to it over its stdin and stdout, one line each way:
//!
//!     (first line out)  ready               the router listens
//!     add <id> <h>      ok | error <why>    relay agent <id>'s states on cells of side <h> (before it starts)
//!     rejected          rejected length=<n> version=<n> value=<n> id=<n> key=<n>
//!
//! The end of stdin (the launcher closed it, or died) closes the router. Exit codes: 0 closed, 2 bad
//! configuration or arguments (one line on stderr).

use std::io::{BufRead, Write};
use std::sync::Arc;

use fluidswarm_agent::keys;
use fluidswarm_agent::relay::{RelayTable, StateRelay};
use zenoh::Wait;

const CONFIG_ENV: &str = "FLUIDSWARM_ROUTER_CONFIG";

fn fail(msg: &str) -> ! {
    eprintln!("fluidswarm router: error: {msg}");
    std::process::exit(2)
}

fn main() {
    fluidswarm_agent::abort_on_panic();
    // Ctrl-C reaches the whole process group; the launcher still needs its router to tell its agents to stop,
    // and closes the router (our stdin) after them. The end of stdin is also how the launcher's death ends us
    // (the pipe closes with it, however it dies), so no death signal tied to the spawning thread is needed.
    // SAFETY: a plain signal disposition, before any other thread exists.
    unsafe { libc::signal(libc::SIGINT, libc::SIG_IGN) };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let run = match args.as_slice() {
        [run] if keys::valid_run_name(run) => run.clone(),
        _ => fail("usage: fluidswarm-router RUN (a run name: 1-64 letters, digits, '-' or '_'), configuration in $FLUIDSWARM_ROUTER_CONFIG"),
    };
    let path = std::env::var(CONFIG_ENV).unwrap_or_else(|_| fail(&format!("{CONFIG_ENV} is not set")));
    let config = zenoh::Config::from_file(&path).unwrap_or_else(|e| fail(&format!("{CONFIG_ENV} {path}: {e}")));
    let session = zenoh::open(config).wait().unwrap_or_else(|e| fail(&format!("cannot open the router: {e}")));
    let table = Arc::new(RelayTable::new(&run));
    let relay = StateRelay::start(&session, table.clone()).unwrap_or_else(|e| fail(&format!("relay: {e}")));
    let mut out = std::io::stdout().lock();
    let say = |out: &mut std::io::StdoutLock, line: &str| writeln!(out, "{line}").and_then(|_| out.flush()).is_ok();
    if !say(&mut out, "ready") {
        std::process::exit(0);
    }
    for line in std::io::stdin().lock().lines() {
        let Ok(line) = line else { break };
        let words: Vec<&str> = line.split_whitespace().collect();
        let reply = match words.as_slice() {
            ["add", id, h] => match (id.parse::<u32>(), h.parse::<f64>()) {
                (Ok(id), Ok(h)) => table.add(id, h).map(|_| "ok".to_string()).unwrap_or_else(|e| format!("error {e}")),
                _ => format!("error add: expected an agent id (0..{}) and a smoothing length", keys::MAX_AGENTS - 1),
            },
            ["rejected"] => format!("rejected {}", table.rejected_line()),
            _ => format!("error unknown request {line:?} (add <id> <h> | rejected)"),
        };
        if !say(&mut out, &reply) {
            break;
        }
    }
    // A last resort if closing hangs: SIGALRM's default action ends the process 5 s later regardless.
    // SAFETY: alarm with an integer argument.
    unsafe { libc::alarm(5) };
    drop(relay);
    let _ = session.close().wait();
}
