use super::*;
use crate::math::Rgb;
use crate::render::PixelSum;

/// A film whose pixel `i` holds `n` samples of `value(i, s)`.
fn film_of(width: u32, n: u32, value: impl Fn(usize, u32) -> f32) -> Film {
    let mut film = Film::new(width, 1);
    for i in 0..width as usize {
        let mut px = PixelSum::default();
        for s in 0..n {
            px.add(Rgb::splat(value(i, s)));
        }
        film.sum[i] = px.sum;
        film.sum_sq[i] = px.sum_sq;
    }
    film.samples = n as u64;
    film.plan = Some(PixelPlan::uniform(width as usize, n, n));
    film
}

/// Adds samples to each pixel of `film` up to its goal, of `value`.
fn render_to_goals(film: &mut Film, value: impl Fn(usize, u32) -> f32) {
    let plan = film.plan.as_mut().unwrap();
    for i in 0..plan.count.len() {
        for s in plan.count[i]..plan.goal[i] {
            let v = value(i, s) as f64;
            for c in 0..3 {
                film.sum[i][c] += v;
                film.sum_sq[i][c] += v * v;
            }
        }
        plan.count[i] = plan.goal[i];
    }
    film.samples = plan.count.iter().copied().max().unwrap() as u64;
}

/// A row of nine pixels in three regions: pixels 0..3 are constant (no
/// noise), pixels 3..6 alternate 0 and 2 (relative standard deviation 1),
/// pixels 6..9 are black.
fn three_regions(i: usize, s: u32) -> f32 {
    match i / 3 {
        0 => 0.5,
        1 => 2.0 * (s % 2) as f32,
        _ => 0.0,
    }
}

#[test]
fn the_threshold_stops_a_pixel_after_two_decisions_in_a_row() {
    let sampling = Sampling::NoiseThreshold {
        threshold: 0.05,
        min_spp: 16,
        max_spp: 4096,
    };
    let mut film = film_of(9, 0, three_regions);
    film.plan = sampling.first_plan(9);
    assert_eq!(film.plan.as_ref().unwrap().goal, [16; 9]);
    render_to_goals(&mut film, three_regions);
    assert!(sampling.decide(&mut film));
    let plan = film.plan.as_ref().unwrap();
    let (t, f) = (true, false);
    assert_eq!(
        plan.met,
        [t, t, f, f, f, f, f, t, t],
        "noise-free pixels met it once, but not those next to noisy ones"
    );
    assert_eq!(plan.goal, [32; 9], "one decision does not stop a pixel");
    render_to_goals(&mut film, three_regions);
    assert!(sampling.decide(&mut film));
    let plan = film.plan.as_ref().unwrap();
    assert_eq!(
        plan.goal,
        [32, 32, 64, 64, 64, 64, 64, 32, 32],
        "the second decision in a row does"
    );
    // The noisy pixels' relative standard error is 1/√(n-1): at most 0.05
    // from 401 samples on, so they meet the threshold at 512 and stop at
    // 1024, well below max_spp; their quiet neighbours go on with them.
    let mut decisions = 2;
    while sampling.decide_after(&mut film, three_regions) {
        decisions += 1;
    }
    let plan = film.plan.as_ref().unwrap();
    assert_eq!(plan.count, [32, 32, 1024, 1024, 1024, 1024, 1024, 32, 32]);
    assert_eq!(plan.count, plan.goal, "stopped pixels rest at their goal");
    assert_eq!(decisions, 6, "pixels went on after 16, 32, ..., 512");
}

#[test]
fn the_threshold_stops_every_pixel_at_max_spp() {
    let sampling = Sampling::NoiseThreshold {
        threshold: 1e-9,
        min_spp: 4,
        max_spp: 12,
    };
    let mut film = film_of(9, 0, three_regions);
    film.plan = sampling.first_plan(9);
    let mut goals = Vec::new();
    loop {
        render_to_goals(&mut film, three_regions);
        if !sampling.decide(&mut film) {
            break;
        }
        goals.push(film.plan.as_ref().unwrap().goal[4]);
    }
    assert_eq!(goals, [8, 12], "doubling, then max_spp");
    assert_eq!(
        film.plan.unwrap().count,
        [8, 8, 12, 12, 12, 12, 12, 8, 8],
        "noise-free pixels stop after two decisions, the noisy ones and their neighbours at max_spp"
    );
}

impl Sampling {
    /// Renders `film` to its goals with `value`, then decides.
    fn decide_after(&self, film: &mut Film, value: impl Fn(usize, u32) -> f32) -> bool {
        render_to_goals(film, value);
        self.decide(film)
    }
}

#[test]
fn a_budget_spends_exactly_spp_times_pixels_and_most_where_the_noise_is() {
    let noisy = |i: usize, s: u32| -> f32 {
        // Pixels 0..8 are noisy in different degrees, the rest constant.
        if i < 8 {
            (s.wrapping_mul(2654435761u32).wrapping_add(i as u32 * 97) >> 28) as f32
                * (i + 1) as f32
        } else {
            1.0
        }
    };
    let sampling = Sampling::Budget { spp: 32 };
    let pixels = 40;
    let mut film = film_of(pixels, 0, noisy);
    film.plan = sampling.first_plan(pixels as usize);
    assert_eq!(film.plan.as_ref().unwrap().goal[0], 8, "a quarter first");
    let mut decisions = 0;
    while sampling.decide_after(&mut film, noisy) {
        decisions += 1;
    }
    assert_eq!(decisions, 2, "at a half and at all of the budget");
    let plan = film.plan.as_ref().unwrap();
    assert_eq!(
        plan.total(),
        32 * pixels as u64,
        "the whole budget, no more"
    );
    let noisy_mean = plan.count[..8].iter().sum::<u32>() as f64 / 8.0;
    let quiet_mean = plan.count[8..].iter().sum::<u32>() as f64 / 32.0;
    assert!(
        noisy_mean > 4.0 * quiet_mean,
        "{noisy_mean} against {quiet_mean}"
    );
    assert!(plan.count.iter().all(|&c| c >= 8), "no pixel loses samples");
}

#[test]
fn allocation_adds_up_and_breaks_ties_by_index() {
    assert_eq!(allocate(10, &[1.0, 1.0, 1.0]), [4, 3, 3]);
    assert_eq!(allocate(7, &[0.0, 3.0, 1.0]), [0, 5, 2]);
    assert_eq!(allocate(5, &[0.0, 0.0]), [3, 2], "no deficits: evenly");
    let deficits: Vec<f64> = (0..1000).map(|i| ((i * 37) % 101) as f64 * 0.013).collect();
    let extra = allocate(123_457, &deficits);
    assert_eq!(extra.iter().map(|&e| e as u64).sum::<u64>(), 123_457);
    assert_eq!(extra, allocate(123_457, &deficits), "deterministic");
}

#[test]
fn sampling_texts_round_trip_and_bad_ones_are_refused() {
    for sampling in [
        Sampling::Uniform,
        Sampling::Budget { spp: 64 },
        Sampling::NoiseThreshold {
            threshold: 0.025,
            min_spp: 16,
            max_spp: 4096,
        },
    ] {
        assert_eq!(sampling.to_string().parse::<Sampling>(), Ok(sampling));
    }
    for bad in [
        "",
        "adaptive",
        "adaptive x",
        "noise-threshold 0.05 16",
        "noise-threshold -1 1..2",
        "noise-threshold NaN 1..2",
        "uniform 3",
    ] {
        assert!(bad.parse::<Sampling>().is_err(), "{bad}");
    }
}

#[test]
fn relative_error_uses_the_floor_below_a_tenth() {
    // Pixel 4: mean 1, standard deviation 1 over 16 samples: stderr about
    // 0.258 (the unbiased variance 16/15). Pixel 8: black, no error.
    let film = film_of(9, 16, three_regions);
    let want = (16.0f64 / 15.0).sqrt() / 4.0;
    assert!((relative_error(&film, 4) - want).abs() < 1e-12);
    assert_eq!(relative_error(&film, 0), 0.0);
    assert_eq!(relative_error(&film, 8), 0.0);
    // A dim noisy pixel is judged against 0.1, not its own mean.
    let dim = film_of(1, 16, |_, s| 0.02 * (s % 2) as f32);
    let stderr = (0.01f64 * 0.01 * 16.0 / 15.0 / 16.0).sqrt();
    assert!((relative_error(&dim, 0) - stderr / RELATIVE_FLOOR).abs() < 1e-9);
}
