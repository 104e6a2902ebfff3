use multistep_sim::experiments::*;
fn main() {
    let s = CurveLimitsSetup::seed001().unwrap();
    let args: Vec<String> = std::env::args().collect();
    let jl: f64 = args[1].parse().unwrap();
    let fam = &args[2];
    let angle: f64 = args[3].parse().unwrap();
    let period: f64 = args[4].parse().unwrap();
    let mut m = s.motor.clone();
    m.load_inertia = jl;
    let t = std::time::Instant::now();
    let r = s.run(&m, fam, angle, period, false).unwrap();
    println!("{:?} lost={} first={:?} err {:.2}..{:.2} final {:.2} sim {:.4}s wall {:.3}s zeta {:.3} fn {:.1}",
        fam, r.lost_steps, r.first_loss_s, r.min_following_error_deg, r.max_following_error_deg, r.final_error_deg, r.simulated_s, t.elapsed().as_secs_f64(), r.damping_ratio, r.natural_frequency_hz);
}
