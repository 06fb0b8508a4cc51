//! Assignment of patches to ranks by weight (particle count): a pure
//! function of the weights and the number of ranks, so every rank computes
//! the same map without communicating. Below both the simulation and its
//! levels (a level rebalances itself with it; the simulation makes the first
//! assignment), so neither reaches up into the other for it.

/// Assigns items of the given weights to `nranks` ranks: largest first to
/// the least-loaded rank (ties to the lowest rank). Deterministic.
pub fn balance(weights: &[u64], nranks: usize) -> Vec<i32> {
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by(|&a, &b| weights[b].cmp(&weights[a]).then(a.cmp(&b)));
    let mut load = vec![0u64; nranks];
    let mut owner = vec![0i32; weights.len()];
    for k in order {
        let r = (0..nranks).min_by_key(|&r| (load[r], r)).unwrap_or(0);
        owner[k] = r as i32;
        load[r] += weights[k];
    }
    owner
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn balance_is_greedy_and_deterministic() {
        let o = balance(&[10, 1, 7, 3, 3], 2);
        let mut load = [0u64; 2];
        for (k, &r) in o.iter().enumerate() {
            load[r as usize] += [10, 1, 7, 3, 3][k];
        }
        // Largest first to the least loaded: 10 -> 0, 7 -> 1, 3 -> 1, 3 -> 0
        // (tie at 10, lowest rank), 1 -> 1. Within Graham's 4/3 bound of the
        // optimum 12.
        assert_eq!(o, vec![0, 1, 1, 1, 0]);
        assert_eq!(load, [13, 11]);
        assert_eq!(o, balance(&[10, 1, 7, 3, 3], 2));
    }
}
