#!/usr/bin/env python3
"""Mutation audit of the board path: plants one plausible bug at a time in the link crate
or the controller and runs the two crates' own tests (no Verilator), which must fail.

    python3 tools/mutation_audit.py          # every mutant
    python3 tools/mutation_audit.py 3 5      # mutants 3 and 5 (numbered from 1)

Run from the repository root on a clean tree: each mutant is written into its file, the
tests run, and the file is restored (also on Ctrl-C). Prints one line per mutant: caught
or not, by which crate, the failing tests, and the time taken (build included).
"""
import os
import subprocess
import sys
import time

C = "crates/controller/src/"
# (what the bug is, file, text replaced, replacement)
MUTANTS = [
    ('tracking stream closed one step long',
     C + "backend/fpga/stream.rs",
     'let n = u32::try_from(f.coded()).unwrap_or(u32::MAX);',
     'let n = u32::try_from(f.coded() + 1).unwrap_or(u32::MAX);'),
    ('position readback without sign extension',
     'crates/link/src/regs.rs',
     'i64::from(raw as i32) + offset',
     'i64::from(raw) + offset'),
    ('after a board reset, idle axes with a changed count not marked lost',
     C + "backend/fpga/poll.rs",
     '            self.events.push_back((i, PinEvent::Lost { why }));\n            ax.count = count;',
     '            if moved {\n                self.events.push_back((i, PinEvent::Lost { why }));\n            }\n            ax.count = count;'),
    ('CRC-error resync dropping the whole frame',
     'crates/link/src/frame.rs',
     '                    self.buf.drain(..1);',
     '                    self.buf.drain(..REPLY_LEN);'),
    ('a board reset leaving the axis trusted',
     C + "board/advance.rs",
     '                ax.homed = false;\n                ax.trusted = false;\n                ax.marked = false;\n                self.persist(i);\n            }\n            PinEvent::Late',
     '                ax.homed = false;\n                ax.marked = false;\n                self.persist(i);\n            }\n            PinEvent::Late'),
    ('the half-turn tie in the short-way rule',
     C + "board.rs",
     '    if 2 * r > p {',
     '    if 2 * r >= p {'),
    ('requests sent with one sequence number (never advanced)',
     'crates/link/src/host.rs',
     '        req.seq = self.seq;\n        self.seq = self.seq.wrapping_add(1);\n        self.exchange(&req.encode(), req)',
     '        req.seq = self.seq;\n        self.exchange(&req.encode(), req)'),
    ('a start whose outcome is unknown left trusted',
     C + "backend/fpga/poll.rs",
     '        if self.doubt != 0 {\n            self.start_in_doubt();\n        }',
     ''),
    ("the stream's steps ahead of the count ignored by a tracking stop",
     C + "backend/fpga.rs",
     '            f.committed_ahead((ax.count - f.count0).unsigned_abs())',
     '            let _ = f;\n            0'),
    ('the Hall stop ramp a step short (floor, not ceil)',
     C + "backend/fpga/load.rs",
     'let steps = multistep_core::stop_distance(v, amax, None).ceil().max(1.0) as u64;',
     'let steps = multistep_core::stop_distance(v, amax, None).floor().max(1.0) as u64;'),
    ("estop writes 0 to the board's Estop register",
     C + "backend/fpga.rs",
     'l.write(Reg::Board(BoardReg::Estop), 1)',
     'l.write(Reg::Board(BoardReg::Estop), 0)'),
    ("an adopted board's motion of unknown end not reported",
     C + "backend/fpga.rs",
     '(r.end_tick == session::UNKNOWN_END).then_some(r.dir)',
     '(r.end_tick != session::UNKNOWN_END).then_some(r.dir)'),
    ("the board's arm lifetime written as one clock",
     C + "backend/fpga/sync.rs",
     'data: (s * self.params.clock_hz).clamp(1.0, f64::from(u32::MAX)) as u32,',
     'data: (s * 0.0).clamp(1.0, f64::from(u32::MAX)) as u32,'),
    ('a reset board not claimed with a new token',
     C + "backend/fpga/poll.rs",
     '        l.write(Reg::Board(BoardReg::Session), token)?;\n        self.session = token;',
     '        self.session = token;'),
]
PACKAGES = ["multistep-link", "multistep-controller"]


def run_tests():
    """(caught by, failing tests) or (None, []) when every test passed."""
    for pkg in PACKAGES:
        r = subprocess.run(["cargo", "test", "-q", "-p", pkg], capture_output=True, text=True)
        if r.returncode != 0:
            log = r.stdout + r.stderr
            # the names listed under "failures:" after the failing tests' output
            block = log.rsplit("\nfailures:\n", 1)[-1].split("\n\n")[0]
            failing = [l.strip() for l in block.splitlines() if l.startswith("    ")]
            if not failing and "could not compile" in log:
                failing = ["(does not compile)"]
            return pkg, failing
    return None, []


def main(args):
    picks = [int(a) - 1 for a in args] or range(len(MUTANTS))
    missed = 0
    for k in picks:
        what, path, old, new = MUTANTS[k]
        text = open(path).read()
        if text.count(old) != 1:
            print(f"M{k + 1} {what}: its text is in {path} {text.count(old)} times, not once")
            missed += 1
            continue
        t0 = time.time()
        try:
            open(path, "w").write(text.replace(old, new))
            pkg, failing = run_tests()
        finally:
            open(path, "w").write(text)
        verdict = f"caught by {pkg}" if pkg else "NOT CAUGHT"
        missed += pkg is None
        print(f"M{k + 1} {what}: {verdict} ({time.time() - t0:.0f} s); failing: {failing[:4]}",
              flush=True)
    return 1 if missed else 0


if __name__ == "__main__":
    if not os.path.isdir("crates/controller"):
        sys.exit("run from the repository root")
    sys.exit(main(sys.argv[1:]))
