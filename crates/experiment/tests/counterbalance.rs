//! Property tests of the Latin square and the Williams design.

use experiment::counterbalance::{latin_square, williams};
use proptest::prelude::*;

/// Every row is a permutation of 0..n and each condition appears `per`
/// times in each position.
fn assert_latin(rows: &[Vec<usize>], n: usize, per: usize) {
    for (r, row) in rows.iter().enumerate() {
        let mut sorted = row.clone();
        sorted.sort();
        assert_eq!(
            sorted,
            (0..n).collect::<Vec<_>>(),
            "row {r} is a permutation"
        );
    }
    for pos in 0..n {
        let mut count = vec![0; n];
        for row in rows {
            count[row[pos]] += 1;
        }
        assert!(count.iter().all(|&c| c == per), "position {pos}: {count:?}");
    }
}

/// Count of each ordered adjacent pair (a, b) across all rows.
fn adjacent_pairs(rows: &[Vec<usize>], n: usize) -> Vec<Vec<usize>> {
    let mut m = vec![vec![0; n]; n];
    for row in rows {
        for w in row.windows(2) {
            m[w[0]][w[1]] += 1;
        }
    }
    m
}

proptest! {
    #[test]
    fn latin_square_is_latin(n in 1usize..40) {
        let rows = latin_square(n);
        prop_assert_eq!(rows.len(), n);
        assert_latin(&rows, n, 1);
    }

    #[test]
    fn williams_is_latin_and_carryover_balanced(n in 2usize..40) {
        let rows = williams(n);
        let copies = if n % 2 == 0 { 1 } else { 2 };
        prop_assert_eq!(rows.len(), n * copies);
        assert_latin(&rows, n, copies);
        let pairs = adjacent_pairs(&rows, n);
        for (a, row) in pairs.iter().enumerate() {
            for (b, &c) in row.iter().enumerate() {
                let want = if a == b { 0 } else { copies };
                prop_assert_eq!(c, want, "pair ({}, {}) in n = {}", a, b, n);
            }
        }
    }
}

#[test]
fn williams_first_rows_match_the_textbook() {
    // Jones & Kenward: n = 4 -> 0 1 3 2 / 1 2 0 3 / 2 3 1 0 / 3 0 2 1.
    assert_eq!(
        williams(4),
        vec![
            vec![0, 1, 3, 2],
            vec![1, 2, 0, 3],
            vec![2, 3, 1, 0],
            vec![3, 0, 2, 1]
        ]
    );
    // n = 3: the square 0 1 2 / 1 2 0 / 2 0 1 and its mirror.
    assert_eq!(williams(3)[0], vec![0, 1, 2]);
    assert_eq!(williams(3)[3], vec![2, 1, 0]);
    assert!(williams(0).is_empty());
    assert_eq!(williams(1), vec![vec![0], vec![0]]);
}

#[test]
fn cyclic_square_is_not_carryover_balanced() {
    // The reason Williams exists: in the cyclic square 0 is always followed by 1.
    let pairs = adjacent_pairs(&latin_square(5), 5);
    assert_eq!(pairs[0][1], 4);
    assert_eq!(pairs[1][0], 0);
}
