//! A pseudo-terminal: the simulated board's UART as a serial device a host program opens.

use std::os::fd::{AsRawFd, FromRawFd, OwnedFd};

/// The master side (ours) and the slave's device path (the host's).
#[derive(Debug)]
pub struct Pty {
    master: OwnedFd,
    /// Held open so the master never reads a hang-up between two host sessions.
    _slave: OwnedFd,
    pub path: String,
}

fn last_error(what: &str) -> std::io::Error {
    let e = std::io::Error::last_os_error();
    std::io::Error::new(e.kind(), format!("{what}: {e}"))
}

impl Pty {
    /// Opens a pair in raw mode (no echo, no line editing: bytes pass unchanged).
    pub fn open() -> std::io::Result<Pty> {
        // SAFETY: plain libc calls on descriptors this function owns; `name` is a
        // NUL-terminated buffer ptsname_r fills.
        unsafe {
            let fd = libc::posix_openpt(libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC);
            if fd < 0 {
                return Err(last_error("posix_openpt"));
            }
            let master = OwnedFd::from_raw_fd(fd);
            if libc::grantpt(fd) != 0 || libc::unlockpt(fd) != 0 {
                return Err(last_error("grantpt/unlockpt"));
            }
            let mut name = [0 as libc::c_char; 128];
            if libc::ptsname_r(fd, name.as_mut_ptr(), name.len()) != 0 {
                return Err(last_error("ptsname_r"));
            }
            let path = std::ffi::CStr::from_ptr(name.as_ptr())
                .to_string_lossy()
                .into_owned();
            let sfd = libc::open(
                name.as_ptr(),
                libc::O_RDWR | libc::O_NOCTTY | libc::O_CLOEXEC,
            );
            if sfd < 0 {
                return Err(last_error("open the pty slave"));
            }
            let slave = OwnedFd::from_raw_fd(sfd);
            let mut t: libc::termios = std::mem::zeroed();
            if libc::tcgetattr(sfd, &mut t) != 0 {
                return Err(last_error("tcgetattr"));
            }
            libc::cfmakeraw(&mut t);
            if libc::tcsetattr(sfd, libc::TCSANOW, &t) != 0 {
                return Err(last_error("tcsetattr"));
            }
            let fl = libc::fcntl(fd, libc::F_GETFL);
            if fl < 0 || libc::fcntl(fd, libc::F_SETFL, fl | libc::O_NONBLOCK) != 0 {
                return Err(last_error("fcntl O_NONBLOCK"));
            }
            Ok(Pty {
                master,
                _slave: slave,
                path,
            })
        }
    }

    /// Waits up to `timeout_ms` for host bytes; true if some are there.
    pub fn wait_readable(&self, timeout_ms: i32) -> bool {
        let mut p = libc::pollfd {
            fd: self.master.as_raw_fd(),
            events: libc::POLLIN,
            revents: 0,
        };
        // SAFETY: one valid pollfd.
        let n = unsafe { libc::poll(&mut p, 1, timeout_ms) };
        n > 0 && p.revents & libc::POLLIN != 0
    }

    /// Whatever the host has sent (never blocks).
    pub fn read_available(&self, out: &mut Vec<u8>) {
        let mut buf = [0u8; 256];
        loop {
            // SAFETY: reads into a buffer of the given length.
            let n =
                unsafe { libc::read(self.master.as_raw_fd(), buf.as_mut_ptr().cast(), buf.len()) };
            if n <= 0 {
                return;
            }
            out.extend_from_slice(&buf[..n as usize]);
        }
    }

    /// Sends bytes to the host; what does not fit the terminal's buffer is dropped, as a
    /// UART's bytes are when nobody reads them.
    pub fn write(&self, bytes: &[u8]) {
        // SAFETY: writes from a buffer of the given length.
        let _ = unsafe { libc::write(self.master.as_raw_fd(), bytes.as_ptr().cast(), bytes.len()) };
    }
}

impl AsRawFd for Pty {
    /// The master side's descriptor (to poll it with others).
    fn as_raw_fd(&self) -> std::os::fd::RawFd {
        self.master.as_raw_fd()
    }
}
