//! Connected regions and distances on the grid of thumbnail blocks that clip recovery works on
//! (`recovery.rs`): which clipped blocks form one region, and how deep inside it each lies.

/// The 8 neighbours of block `b` of a `w × h` grid that lie inside it.
fn neighbours(b: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (x, y) = ((b % w) as isize, (b / w) as isize);
    (-1..=1)
        .flat_map(move |dy| (-1..=1).map(move |dx| (x + dx, y + dy)))
        .filter(move |&(nx, ny)| {
            (nx, ny) != (x, y) && nx >= 0 && ny >= 0 && nx < w as isize && ny < h as isize
        })
        .map(move |(nx, ny)| ny as usize * w + nx as usize)
}

/// Connected components (8-neighbour) of the blocks where `mask` is true, in scan order.
pub(super) fn components(w: usize, h: usize, mask: &[bool]) -> Vec<Vec<usize>> {
    let mut label = vec![usize::MAX; w * h];
    let mut out = Vec::new();
    for start in 0..w * h {
        if !mask[start] || label[start] != usize::MAX {
            continue;
        }
        let id = out.len();
        let mut comp = vec![start];
        label[start] = id;
        let mut i = 0;
        while i < comp.len() {
            let b = comp[i];
            i += 1;
            for n in neighbours(b, w, h) {
                if mask[n] && label[n] == usize::MAX {
                    label[n] = id;
                    comp.push(n);
                }
            }
        }
        comp.sort_unstable();
        out.push(comp);
    }
    out
}

/// Chessboard distance, in blocks, from each block to the nearest unclipped block of the
/// picture (the picture's border is not a boundary: a region cut by it may go on beyond it).
pub(super) fn distance_to_unclipped(w: usize, h: usize, mask: &[bool]) -> Vec<u32> {
    let mut dist = vec![u32::MAX; w * h];
    let mut queue: std::collections::VecDeque<usize> = (0..w * h).filter(|&b| !mask[b]).collect();
    for &b in &queue {
        dist[b] = 0;
    }
    while let Some(b) = queue.pop_front() {
        for n in neighbours(b, w, h) {
            if dist[n] == u32::MAX {
                dist[n] = dist[b] + 1;
                queue.push_back(n);
            }
        }
    }
    dist
}
