//! Prints the 57 mm motor's steady-state torque bound at a few speeds (for docs/EXPERIMENTS.md).
use multistep_sim::{analysis, DriverConfig, Motor};
fn main() {
    let m = Motor::load("57mm").unwrap();
    let d = DriverConfig::for_motor(&m);
    for deg_s in [2000.0, 5000.0, 7853.0, 9449.0, 10521.0, 12500.0, 13500.0] {
        let w = f64::to_radians(deg_s);
        let v = analysis::max_torque(&m, d.current, d.supply_voltage, w).unwrap_or(f64::NAN);
        let sq = analysis::pull_out_bound(&m, &d, w).unwrap_or(f64::NAN);
        println!("{deg_s:8.0} °/s  {w:7.1} rad/s  |v|≤V: {v:.3} N·m   |v|≤4V/π: {sq:.3} N·m");
    }
}
