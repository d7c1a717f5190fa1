//! The operating system's primitives a lockstep exchange is made of, measured on this machine
//! (docs/benchmarks/realtime.md, "Primitives"; scripts/realtime_floor.sh runs it):
//!
//! - `futex`: two threads of one process hand a token back and forth through a Mutex + Condvar (a futex wait
//!   and wake each way): wall and CPU per hand-over.
//! - `pipe_pingpong`, `tcp_pingpong`: two processes send a 104-byte record back and forth over a pipe pair or a
//!   TCP loopback connection (TCP_NODELAY): wall and CPU (both processes) per round trip.
//! - `tcp_stream`: one process writes 104-byte records to another over TCP loopback, one write(2) per record
//!   (no batching), then 64 records per write (what Zenoh's batching can do): CPU (both) per record.
//!
//!     primitives [ROUNDS]      prints one `name=value` line per figure
//!
//! Unix only; no Zenoh.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::{Arc, Condvar, Mutex};
use std::time::Instant;

const RECORD: usize = 104;

fn cpu_of(who: libc::c_int) -> f64 {
    // SAFETY: getrusage writes into the struct we own.
    let mut ru: libc::rusage = unsafe { std::mem::zeroed() };
    unsafe { libc::getrusage(who, &mut ru) };
    let t = |tv: libc::timeval| tv.tv_sec as f64 + tv.tv_usec as f64 * 1e-6;
    t(ru.ru_utime) + t(ru.ru_stime)
}

/// CPU of this process and its waited-for children.
fn cpu_all() -> f64 {
    cpu_of(libc::RUSAGE_SELF) + cpu_of(libc::RUSAGE_CHILDREN)
}

fn futex(rounds: u32) {
    let pair = Arc::new((Mutex::new(0u32), Condvar::new()));
    let other = Arc::clone(&pair);
    let (c0, t0) = (cpu_all(), Instant::now());
    let h = std::thread::spawn(move || {
        let (m, cv) = &*other;
        for i in 0..rounds {
            let mut v = m.lock().unwrap();
            while *v != 2 * i + 1 {
                v = cv.wait(v).unwrap();
            }
            *v += 1;
            cv.notify_one();
        }
    });
    let (m, cv) = &*pair;
    for i in 0..rounds {
        let mut v = m.lock().unwrap();
        *v += 1;
        cv.notify_one();
        while *v != 2 * i + 2 {
            v = cv.wait(v).unwrap();
        }
    }
    h.join().unwrap();
    let n = 2.0 * rounds as f64; // hand-overs
    println!(
        "futex_handover_wall_us={:.2} futex_handover_cpu_us={:.2}",
        t0.elapsed().as_secs_f64() / n * 1e6,
        (cpu_all() - c0) / n * 1e6
    );
}

/// Fork a child that runs `child` and exits; the parent gets its pid.
fn fork(child: impl FnOnce()) -> libc::pid_t {
    // SAFETY: the child runs plain Rust on its own copy and leaves with _exit (no destructors of the parent's).
    let pid = unsafe { libc::fork() };
    if pid == 0 {
        child();
        unsafe { libc::_exit(0) };
    }
    pid
}

fn wait(pid: libc::pid_t) {
    let mut status = 0;
    // SAFETY: waiting for our own child.
    unsafe { libc::waitpid(pid, &mut status, 0) };
}

fn pingpong<S: Read + Write>(name: &str, rounds: u32, mut mine: S, child: impl FnOnce()) {
    let (c0, t0) = (cpu_all(), Instant::now());
    let pid = fork(child);
    let mut buf = [0u8; RECORD];
    for _ in 0..rounds {
        mine.write_all(&buf).unwrap();
        mine.read_exact(&mut buf).unwrap();
    }
    drop(mine);
    wait(pid);
    let n = rounds as f64;
    println!(
        "{name}_roundtrip_wall_us={:.2} {name}_roundtrip_cpu_us={:.2}",
        t0.elapsed().as_secs_f64() / n * 1e6,
        (cpu_all() - c0) / n * 1e6
    );
}

fn echo<S: Read + Write>(mut s: S, rounds: u32) {
    let mut buf = [0u8; RECORD];
    for _ in 0..rounds {
        s.read_exact(&mut buf).unwrap();
        s.write_all(&buf).unwrap();
    }
}

/// A read+write pair of pipe ends as one stream.
struct Pipes(std::fs::File, std::fs::File);
impl Read for Pipes {
    fn read(&mut self, b: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(b)
    }
}
impl Write for Pipes {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.1.write(b)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn pipe() -> (std::fs::File, std::fs::File) {
    use std::os::fd::FromRawFd;
    let mut fds = [0; 2];
    // SAFETY: pipe writes two fds we then own.
    unsafe {
        libc::pipe(fds.as_mut_ptr());
        (std::fs::File::from_raw_fd(fds[0]), std::fs::File::from_raw_fd(fds[1]))
    }
}

fn tcp_pair() -> (TcpStream, TcpStream) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let a = TcpStream::connect(l.local_addr().unwrap()).unwrap();
    let (b, _) = l.accept().unwrap();
    a.set_nodelay(true).unwrap();
    b.set_nodelay(true).unwrap();
    (a, b)
}

fn stream(rounds: u32, per_write: usize) {
    let (mut a, b) = tcp_pair();
    let total = rounds as usize * per_write;
    let (c0, t0) = (cpu_all(), Instant::now());
    let pid = fork(move || {
        let mut b = b;
        let mut buf = vec![0u8; 65536];
        let mut left = total * RECORD;
        while left > 0 {
            let n = b.read(&mut buf).unwrap();
            if n == 0 {
                break;
            }
            left -= n;
        }
    });
    let chunk = vec![0u8; RECORD * per_write];
    for _ in 0..rounds {
        a.write_all(&chunk).unwrap();
    }
    drop(a);
    wait(pid);
    println!(
        "tcp_stream_{per_write}_per_write_cpu_us_per_record={:.3} tcp_stream_{per_write}_per_write_wall_us_per_record={:.3}",
        (cpu_all() - c0) / total as f64 * 1e6,
        t0.elapsed().as_secs_f64() / total as f64 * 1e6
    );
}

fn main() {
    let rounds: u32 = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(100_000);
    futex(rounds);
    let ((r0, w0), (r1, w1)) = (pipe(), pipe());
    pingpong("pipe", rounds, Pipes(r0, w1), move || echo(Pipes(r1, w0), rounds));
    let (a, b) = tcp_pair();
    pingpong("tcp", rounds, a, move || echo(b, rounds));
    stream(rounds, 1);
    stream(rounds / 64 + 1, 64);
}
