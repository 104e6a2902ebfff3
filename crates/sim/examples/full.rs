use multistep_sim::experiments::*;
fn main() {
    let mut s = CurveLimitsSetup::seed001().unwrap();
    let args: Vec<String> = std::env::args().collect();
    if args.len() > 1 {
        s.motor.damping_ratio = args[1].parse().unwrap();
    }
    if args.len() > 2 {
        s.cfg.driver.bandwidth_hz = args[2].parse().unwrap();
    }
    let t = std::time::Instant::now();
    let r = curve_limits(&s).unwrap();
    println!(
        "J_L {:.3e} zeta {:.3} fn {:.1}",
        r.load_inertia, r.damping_ratio, r.natural_frequency_hz
    );
    for f in FAMILIES {
        println!(
            "{:12} {:8.1} {:8.1}  err {:?} {:?}",
            f,
            r.max_angle_deg[f],
            r.min_time_360_ms[f],
            r.error_at_max_angle[f],
            r.error_at_min_time[f]
        );
    }
    println!("wall {:.1}s", t.elapsed().as_secs_f64());
}
