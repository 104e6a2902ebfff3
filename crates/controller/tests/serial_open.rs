//! A serial link opened after a host died mid-request: the board's answer to the dead
//! host's last request (over a real pseudo-terminal) is not taken for the new host's reply.

use multistep_controller::backend::fpga::{serial_opener, LinkSpec};
use multistep_hil::pty::Pty;
use multistep_link::{AxisReg, HostLink, Reg, Reply, Request, Status};
use std::time::Duration;

/// The line's reply timeout: the opener listens for a tenth of it (0.5 s), so a late thread
/// on a loaded machine still writes within it.
const TIMEOUT: Duration = Duration::from_secs(5);

/// The dead host's last request had seq 0, as the new host's first: its reply (32, the
/// Status register's idle SYNC bit) comes before the new host opens the line and again
/// while it opens it.
#[test]
fn a_reply_to_a_dead_hosts_request_is_not_taken_for_the_first_reply() {
    let pty = std::sync::Arc::new(Pty::open().expect("a pseudo-terminal"));
    let stale = Reply {
        seq: 0,
        status: Status::Ok,
        data: 32,
    }
    .encode();
    pty.write(&stale);
    let board = {
        let pty = pty.clone();
        std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            pty.write(&stale);
            // then the board answers the new host's request: axis 0 at 1500
            assert!(pty.wait_readable(10_000), "no request came");
            let mut got = Vec::new();
            pty.read_available(&mut got);
            let req = Request::decode(&got).expect("one request frame");
            pty.write(
                &Reply {
                    seq: req.seq,
                    status: Status::Ok,
                    data: 1500,
                }
                .encode(),
            );
        })
    };
    let spec = LinkSpec {
        device: pty.path.clone(),
        baud: 115_200,
        timeout: TIMEOUT,
    };
    let port = serial_opener(&spec)().expect("the pty opens");
    let mut link = HostLink::new(port);
    assert_eq!(link.read(Reg::Axis(0, AxisReg::Position)).unwrap(), 1500);
    board.join().unwrap();
}
