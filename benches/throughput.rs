fn main() {
    use gpu_amcs::engine::*;
    use gpu_amcs::kinematics::tx60;
    let m = tx60();
    let pts = gpu_amcs::points::generate(&m, 50, &Default::default(), 1).unwrap();
    let pb = Problem::new(m, &pts, &Reference::Calibrated, 1).unwrap();
    let mut ev = CpuEvaluator::new(pb);
    let mut w = vec![0.0; 1_000_000];
    for _ in 0..5 {
        let t = std::time::Instant::now();
        ev.evaluate(0, &mut w, None).unwrap();
        println!("{:.3}s", t.elapsed().as_secs_f64());
    }
}
