//! Which view each iteration trains on, and which views are held out.

use rand::seq::SliceRandom;

use crate::model::rng::stream;

/// The papers' split: view `i` (in camera order) is held out for testing when
/// `i % every == 0` (3DGS's `llffhold` = 8); `every == 0` holds out nothing.
/// Returns (train indices, test indices).
pub fn split(count: usize, every: usize) -> (Vec<usize>, Vec<usize>) {
    (0..count).partition(|&i| every == 0 || i % every != 0)
}

/// The train view used at `iteration` (0-based): the views are visited in a
/// fresh seeded permutation per pass (as 3DGS refills its camera stack), so
/// the order depends only on (seed, iteration) and a resumed run sees the
/// same views as an uninterrupted one.
pub fn view_at(train: &[usize], seed: u64, iteration: u64) -> usize {
    let n = train.len() as u64;
    let pass = iteration / n;
    let mut order = train.to_vec();
    order.shuffle(&mut stream(seed, pass));
    order[(iteration % n) as usize]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every 8th view from the first is held out; 0 keeps all.
    #[test]
    fn split_every_eighth() {
        let (tr, te) = split(17, 8);
        assert_eq!(te, vec![0, 8, 16]);
        assert_eq!(tr.len(), 14);
        assert_eq!(split(5, 0).1, Vec::<usize>::new());
    }

    /// Each pass visits every train view once; passes differ; the order is a
    /// function of (seed, iteration) only.
    #[test]
    fn passes_are_permutations() {
        let train: Vec<usize> = (1..11).collect();
        let mut first: Vec<usize> = (0..10).map(|i| view_at(&train, 3, i)).collect();
        let second: Vec<usize> = (10..20).map(|i| view_at(&train, 3, i)).collect();
        assert_ne!(first, second);
        first.sort();
        assert_eq!(first, train);
        assert_eq!(view_at(&train, 3, 15), view_at(&train, 3, 15));
    }
}
