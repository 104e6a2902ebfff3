use multistep_hdl::*;
fn main() {
    let p = CoreParams {
        axes: 2,
        ..Default::default()
    };
    let d = Design::new(&p, Arch::Tdm).unwrap();
    let dir = std::path::Path::new("/tmp/hdl-scratch");
    if let Err(e) = tools::lint(&d, &dir.join("lint")) {
        println!("{e}");
    }
    let di = Design::new(&p, Arch::Independent).unwrap();
    if let Err(e) = tools::lint(&di, &dir.join("linti")) {
        println!("{e}");
    }
    let f = p.frac_bits;
    let m0 = AxisMove::chained(false, 0, &[(40, 20000), (30, 10000), (40, 20000)], f);
    let m1 = AxisMove::chained(true, 0, &[(30, 20000), (20, 10000), (30, 20000)], f);
    println!("{:?}", m0);
    let moves = vec![m0.clone(), m1.clone()];
    let out = tools::simulate(&d, &moves, &dir.join("sim"), 200000).unwrap();
    println!("underrun {} dir {}", out.underrun, out.dir);
    for (a, m) in moves.iter().enumerate() {
        let e = m.edges(f);
        println!("model {:?}", &e[..5]);
        println!("rtl   {:?}", &out.edges[a][..5.min(out.edges[a].len())]);
        println!("eq {}", e == out.edges[a]);
    }
}
