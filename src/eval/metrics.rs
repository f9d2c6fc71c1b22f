//! THROW-AWAY STUB with the `reference` branch's signatures.

#[derive(Clone, Copy, Debug, serde::Serialize, PartialEq)]
pub struct Errors {
    pub mae_shadow: f64,
    pub rmse: f64,
    pub p99: f64,
    pub max: f64,
    pub shadow_pixels: usize,
    pub covered_pixels: usize,
}

pub fn errors(v: &[f32], v_ref: &[f32], covered: &[bool]) -> Errors {
    let mut all = 0.0f64;
    let mut n = 0usize;
    let mut shadow = Vec::new();
    let mut max = 0.0f64;
    for i in 0..v.len() {
        if !covered[i] {
            continue;
        }
        let d = (v[i] - v_ref[i]).abs() as f64;
        all += d * d;
        n += 1;
        max = max.max(d);
        if v[i] < 0.999 || v_ref[i] < 0.999 {
            shadow.push(d);
        }
    }
    shadow.sort_by(f64::total_cmp);
    let p99 = shadow
        .get(((shadow.len() as f64 * 0.99) as usize).min(shadow.len().saturating_sub(1)))
        .copied()
        .unwrap_or(0.0);
    Errors {
        mae_shadow: if shadow.is_empty() {
            0.0
        } else {
            shadow.iter().sum::<f64>() / shadow.len() as f64
        },
        rmse: if n == 0 { 0.0 } else { (all / n as f64).sqrt() },
        p99,
        max,
        shadow_pixels: shadow.len(),
        covered_pixels: n,
    }
}

pub fn error_image(v: &[f32], v_ref: &[f32], covered: &[bool], scale: f32) -> Vec<[u8; 4]> {
    (0..v.len())
        .map(|i| {
            if !covered[i] {
                return [0, 0, 0, 255];
            }
            let e = ((v[i] - v_ref[i]).abs() / scale).clamp(0.0, 1.0);
            [
                (255.0 * e) as u8,
                (255.0 * (1.0 - (2.0 * e - 1.0).abs())) as u8,
                (255.0 * (1.0 - e)) as u8,
                255,
            ]
        })
        .collect()
}
