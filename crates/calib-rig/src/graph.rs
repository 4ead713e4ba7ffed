//! The camera graph: which cameras saw the board in the same frames, and the spanning tree along
//! which the initial camera transforms are chained.
//!
//! Cameras are nodes; two cameras are joined by an edge weighted by the number of frames both
//! saw. The tree is the maximum spanning tree grown from the reference camera (Prim's algorithm):
//! each camera hangs from the already placed camera it shares the most frames with, so every
//! transform is averaged over as many shared views as the data offers and chains stay short.

/// A spanning tree of the camera graph rooted at the reference camera.
#[derive(Debug, Clone, PartialEq)]
pub struct SpanningTree {
    /// `parent[c]`: the camera `c` hangs from (`None` for the reference).
    pub parent: Vec<Option<usize>>,
    /// Cameras in the order they were placed (the reference first): every camera comes after its
    /// parent.
    pub order: Vec<usize>,
    /// `depth[c]`: edges from the reference.
    pub depth: Vec<usize>,
}

/// `shared[a][b]`: frames seen by both `a` and `b` (`seen[f]` lists the cameras of frame `f`).
pub fn shared_frames(num_cameras: usize, seen: &[Vec<usize>]) -> Vec<Vec<usize>> {
    let mut shared = vec![vec![0; num_cameras]; num_cameras];
    for cameras in seen {
        for (i, &a) in cameras.iter().enumerate() {
            for &b in &cameras[i + 1..] {
                shared[a][b] += 1;
                shared[b][a] += 1;
            }
        }
    }
    shared
}

/// The maximum spanning tree from `reference`, or the connected groups of cameras (each sorted,
/// the reference's first) when some cameras share no chain of frames with the reference.
pub fn spanning_tree(
    shared: &[Vec<usize>],
    reference: usize,
) -> Result<SpanningTree, Vec<Vec<usize>>> {
    let n = shared.len();
    let mut parent = vec![None; n];
    let mut depth = vec![0; n];
    let mut placed = vec![false; n];
    let mut order = vec![reference];
    placed[reference] = true;
    while order.len() < n {
        // The heaviest edge from a placed camera to an unplaced one (ties: lowest indices).
        let mut best: Option<(usize, usize, usize)> = None;
        for &a in &order {
            for b in 0..n {
                let w = shared[a][b];
                if !placed[b] && w > 0 && best.is_none_or(|(bw, _, _)| w > bw) {
                    best = Some((w, a, b));
                }
            }
        }
        let Some((_, a, b)) = best else {
            return Err(groups(shared, reference));
        };
        placed[b] = true;
        parent[b] = Some(a);
        depth[b] = depth[a] + 1;
        order.push(b);
    }
    Ok(SpanningTree {
        parent,
        order,
        depth,
    })
}

/// The connected components of the graph, the reference's first.
fn groups(shared: &[Vec<usize>], reference: usize) -> Vec<Vec<usize>> {
    let n = shared.len();
    let mut group = vec![usize::MAX; n];
    let mut out = Vec::new();
    for start in std::iter::once(reference).chain(0..n) {
        if group[start] != usize::MAX {
            continue;
        }
        let id = out.len();
        let mut members = vec![start];
        group[start] = id;
        let mut k = 0;
        while k < members.len() {
            let a = members[k];
            for b in 0..n {
                if shared[a][b] > 0 && group[b] == usize::MAX {
                    group[b] = id;
                    members.push(b);
                }
            }
            k += 1;
        }
        members.sort_unstable();
        out.push(members);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tree_follows_the_most_shared_frames() {
        // 0-1 share 5, 1-2 share 9, 0-2 share 1, 2-3 share 2.
        let seen: Vec<Vec<usize>> = [
            vec![vec![0, 1]; 5],
            vec![vec![1, 2]; 9],
            vec![vec![0, 2]],
            vec![vec![2, 3]; 2],
        ]
        .concat();
        let shared = shared_frames(4, &seen);
        assert_eq!(shared[1][2], 9);
        let tree = spanning_tree(&shared, 0).unwrap();
        assert_eq!(tree.parent, vec![None, Some(0), Some(1), Some(2)]);
        assert_eq!(tree.order, vec![0, 1, 2, 3]);
        assert_eq!(tree.depth, vec![0, 1, 2, 3]);
        let from_2 = spanning_tree(&shared, 2).unwrap();
        assert_eq!(from_2.parent, vec![Some(1), Some(2), None, Some(2)]);
    }

    #[test]
    fn disconnected_cameras_are_reported_by_group() {
        let seen = vec![vec![0, 2], vec![1, 3], vec![3, 4]];
        let shared = shared_frames(5, &seen);
        let groups = spanning_tree(&shared, 2).unwrap_err();
        assert_eq!(groups, vec![vec![0, 2], vec![1, 3, 4]]);
    }
}
