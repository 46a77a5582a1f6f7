//! Condition orders: the cyclic Latin square and the Williams balanced
//! design. Each function returns rows of condition indices `0..n`; row `r`
//! is the order for the `r`-th participant (modulo the number of rows);
//! [`index_from_id`] takes a participant's row from their id.

/// Cyclic Latin square of order `n`: row `i`, position `j` holds
/// `(i + j) mod n`. Every condition appears exactly once in each row and
/// once in each position (column). It does not balance carry-over: `c` is
/// always followed by `c + 1`. (Standard construction; e.g. Kirk,
/// *Experimental Design*, 4th ed., 2013, ch. on Latin-square designs.)
pub fn latin_square(n: usize) -> Vec<Vec<usize>> {
    (0..n)
        .map(|i| (0..n).map(|j| (i + j) % n).collect())
        .collect()
}

/// Williams (1949) balanced Latin design of order `n`.
///
/// Even `n`: the first row is `0, 1, n-1, 2, n-2, 3, …` (alternately
/// stepping up from the start and down from the end) and row `i` adds `i`
/// to every entry mod `n`: `n` rows in which every condition appears once
/// per position and every ordered pair `(a, b)`, `a ≠ b`, appears as
/// adjacent entries exactly once.
///
/// Odd `n`: no single square balances carry-over, so the design is that
/// square followed by its mirror image (every row reversed): `2n` rows,
/// every condition twice per position, every ordered adjacent pair exactly
/// twice.
///
/// Source: E. J. Williams (1949), "Experimental designs balanced for the
/// estimation of residual effects of treatments", *Australian Journal of
/// Scientific Research* A2, 149–168; construction as given in Jones &
/// Kenward, *Design and Analysis of Cross-Over Trials*, 3rd ed., 2014, ch. 4.
pub fn williams(n: usize) -> Vec<Vec<usize>> {
    if n == 0 {
        return Vec::new();
    }
    // First row: 0, 1, n-1, 2, n-2, 3, ...: position j (odd) holds
    // (j + 1) / 2, position j (even, > 0) holds n - j / 2.
    let first: Vec<usize> = std::iter::once(0)
        .chain((1..n).map(|j| if j % 2 == 1 { j.div_ceil(2) } else { n - j / 2 }))
        .collect();
    let mut rows: Vec<Vec<usize>> = (0..n)
        .map(|i| first.iter().map(|&c| (c + i) % n).collect())
        .collect();
    if n % 2 == 1 {
        let mirrored: Vec<Vec<usize>> = rows
            .iter()
            .map(|r| r.iter().rev().copied().collect())
            .collect();
        rows.extend(mirrored);
    }
    rows
}

/// The counterbalancing index from a participant id: its trailing number
/// minus one (`P01` → 0, `sub-12` → 11).
pub fn index_from_id(id: &str) -> Option<usize> {
    let digits: String = id
        .chars()
        .rev()
        .take_while(char::is_ascii_digit)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    let n: usize = digits.parse().ok()?;
    n.checked_sub(1)
}
