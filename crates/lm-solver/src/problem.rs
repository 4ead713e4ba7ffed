//! Problem description: parameter blocks, residual blocks and their structure.
//!
//! A problem is built once with [`ProblemBuilder`] and then solved any number of times. Building
//! validates the structure and precomputes everything the solver needs to scatter each residual
//! block's Jacobian into the block-structured normal equations, so nothing about the structure is
//! recomputed while iterating.
//!
//! Parameter values live in one flat vector `x`; block `i` occupies
//! `x[problem.offset(i)..problem.offset(i) + problem.dim(i)]`, blocks in the order they were added.
//! Steps, gradients, fixed components and covariances use the *tangent* layout, which is the same
//! unless some block has a [`Manifold`] (`problem.tangent_offset(i)`, `problem.tangent_dim(i)`).

use crate::loss::Loss;
use crate::manifold::Manifold;
use std::collections::HashMap;
use std::sync::Arc;

/// Maximum number of parameter blocks one residual block may depend on.
pub const MAX_BLOCKS_PER_RESIDUAL: usize = 16;

/// Handle of a parameter block (its index in insertion order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ParameterBlockId(pub usize);

/// Handle of a residual block (its index in insertion order).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ResidualBlockId(pub usize);

/// Errors in the problem description, reported by [`ProblemBuilder::build`].
#[non_exhaustive]
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ProblemError {
    /// A parameter block was declared with dimension zero.
    #[error("parameter block {block} has dimension 0")]
    EmptyParameterBlock {
        /// The block.
        block: usize,
    },
    /// A residual block was declared with dimension zero.
    #[error("residual block {residual} has dimension 0")]
    EmptyResidualBlock {
        /// The residual block.
        residual: usize,
    },
    /// A residual block names a parameter block that does not exist.
    #[error("residual block {residual} refers to parameter block {block}, which does not exist")]
    UnknownParameterBlock {
        /// The residual block.
        residual: usize,
        /// The missing parameter block.
        block: usize,
    },
    /// A residual block lists the same parameter block twice.
    #[error("residual block {residual} lists parameter block {block} more than once")]
    DuplicateParameterBlock {
        /// The residual block.
        residual: usize,
        /// The repeated parameter block.
        block: usize,
    },
    /// A residual block depends on too many parameter blocks.
    #[error(
        "residual block {residual} depends on {count} parameter blocks; at most {MAX_BLOCKS_PER_RESIDUAL} are supported"
    )]
    TooManyParameterBlocks {
        /// The residual block.
        residual: usize,
        /// How many it lists.
        count: usize,
    },
    /// A residual block depends on two eliminated blocks: the Schur complement then couples
    /// them and block-diagonal elimination is impossible.
    #[error(
        "residual block {residual} depends on two eliminated parameter blocks ({first} and {second}); at most one is allowed"
    )]
    TwoEliminatedBlocks {
        /// The residual block.
        residual: usize,
        /// First eliminated block.
        first: usize,
        /// Second eliminated block.
        second: usize,
    },
    /// A manifold's ambient dimension differs from its parameter block's dimension, or its
    /// tangent dimension is zero.
    #[error(
        "parameter block {block} has dimension {dim} but its manifold expects {ambient} values and has {tangent} degrees of freedom"
    )]
    ManifoldDimension {
        /// The block.
        block: usize,
        /// The block's dimension.
        dim: usize,
        /// The manifold's ambient dimension.
        ambient: usize,
        /// The manifold's tangent dimension.
        tangent: usize,
    },
    /// A residual block's loss group size does not divide its dimension.
    #[error(
        "residual block {residual} has dimension {dim}, which loss groups of {group} do not divide"
    )]
    LossGroup {
        /// The residual block.
        residual: usize,
        /// Its dimension.
        dim: usize,
        /// The group size.
        group: usize,
    },
    /// A residual block's robust loss has a scale that is not finite and positive.
    #[error("residual block {residual}: {reason}")]
    InvalidLoss {
        /// The residual block.
        residual: usize,
        /// What is wrong ([`Loss::check`]).
        reason: String,
    },
    /// A fixed component index is out of range.
    #[error("parameter block {block} has dimension {dim}; component {component} cannot be fixed")]
    ComponentOutOfRange {
        /// The block.
        block: usize,
        /// Its dimension.
        dim: usize,
        /// The offending component.
        component: usize,
    },
    /// No residual blocks.
    #[error("the problem has no residual blocks")]
    NoResiduals,
}

/// How a parameter block takes part in the solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum BlockRole {
    /// Not optimized.
    Constant,
    /// Kept in the reduced system; index into the reduced block list.
    Reduced(usize),
    /// Eliminated by the Schur complement; index into the eliminated block list.
    Eliminated(usize),
}

#[derive(Debug, Clone)]
struct ParameterSpec {
    dim: usize,
    constant: bool,
    eliminate: bool,
    fixed: Vec<usize>,
    manifold: Option<Arc<dyn Manifold>>,
}

#[derive(Debug, Clone)]
struct ResidualSpec {
    dim: usize,
    blocks: Vec<ParameterBlockId>,
    loss: Loss,
    /// Rows per loss group (0: the whole block is one group).
    group: usize,
}

/// Builds a [`Problem`]: declare parameter blocks, then residual blocks that depend on them.
///
/// ```
/// use lm_solver::ProblemBuilder;
/// let mut builder = ProblemBuilder::new();
/// let camera = builder.add_parameter_block(8);
/// let pose = builder.add_parameter_block(6);
/// builder.set_eliminated(pose, true); // Schur-eliminate the pose
/// builder.set_fixed_components(camera, &[2, 3]); // e.g. hold the principal point
/// builder.add_residual_block(108, &[camera, pose]);
/// let problem = builder.build().unwrap();
/// assert_eq!(problem.num_parameters(), 14);
/// assert_eq!(problem.num_free_parameters(), 12);
/// ```
#[derive(Debug, Clone, Default)]
pub struct ProblemBuilder {
    parameters: Vec<ParameterSpec>,
    residuals: Vec<ResidualSpec>,
}

impl ProblemBuilder {
    /// An empty problem.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds a parameter block of dimension `dim`; its values follow the previous block's in the
    /// flat parameter vector.
    pub fn add_parameter_block(&mut self, dim: usize) -> ParameterBlockId {
        self.parameters.push(ParameterSpec {
            dim,
            constant: false,
            eliminate: false,
            fixed: Vec::new(),
            manifold: None,
        });
        ParameterBlockId(self.parameters.len() - 1)
    }

    /// Holds a whole block at its current value (`true`) or optimizes it again (`false`).
    ///
    /// # Panics
    /// If `block` was not returned by this builder.
    pub fn set_constant(&mut self, block: ParameterBlockId, constant: bool) {
        self.parameters[block.0].constant = constant;
    }

    /// Gives a block a [`Manifold`]: it is then moved by `x ⊞ delta`, its Jacobian blocks are
    /// taken with respect to the tangent increment, and its fixed components, gradient and
    /// covariance are in tangent coordinates (see [`crate::manifold`]). The manifold's ambient
    /// dimension must equal the block's dimension (checked by [`ProblemBuilder::build`]).
    ///
    /// # Panics
    /// If `block` was not returned by this builder.
    pub fn set_manifold(&mut self, block: ParameterBlockId, manifold: Arc<dyn Manifold>) {
        self.parameters[block.0].manifold = Some(manifold);
    }

    /// Holds the listed components of a block at their current values; the others are optimized.
    /// Replaces any previous list. Indices are checked by [`ProblemBuilder::build`]. For a block
    /// with a manifold the indices are tangent components.
    ///
    /// # Panics
    /// If `block` was not returned by this builder.
    pub fn set_fixed_components(&mut self, block: ParameterBlockId, components: &[usize]) {
        let mut fixed = components.to_vec();
        fixed.sort_unstable();
        fixed.dedup();
        self.parameters[block.0].fixed = fixed;
    }

    /// Marks a block for elimination by the Schur complement (`true`) or keeps it in the reduced
    /// system (`false`, the default). Each residual block may depend on at most one eliminated
    /// block. Calibration eliminates the per-view poses; bundle adjustment would eliminate points.
    ///
    /// # Panics
    /// If `block` was not returned by this builder.
    pub fn set_eliminated(&mut self, block: ParameterBlockId, eliminate: bool) {
        self.parameters[block.0].eliminate = eliminate;
    }

    /// Adds a residual block of dimension `dim` that depends on `blocks` (in this order, which is
    /// the order the cost function sees them in), with the trivial (squared) loss.
    pub fn add_residual_block(
        &mut self,
        dim: usize,
        blocks: &[ParameterBlockId],
    ) -> ResidualBlockId {
        self.add_residual_block_with_loss(dim, blocks, Loss::Trivial)
    }

    /// Adds a residual block with a robust loss applied to its squared norm.
    pub fn add_residual_block_with_loss(
        &mut self,
        dim: usize,
        blocks: &[ParameterBlockId],
        loss: Loss,
    ) -> ResidualBlockId {
        self.add_residual_block_with_grouped_loss(dim, blocks, loss, 0)
    }

    /// Adds a residual block whose loss applies to each group of `group` consecutive residuals
    /// separately (`group` must divide `dim`; 0 means the whole block): the block's cost is
    /// `sum_g rho(|r_g|^2) / 2`. A calibration view, say, is one residual block of `2 N` pixel
    /// residuals with a robust loss per point (`group = 2`), so an outlier corner is
    /// down-weighted without the rest of its view.
    pub fn add_residual_block_with_grouped_loss(
        &mut self,
        dim: usize,
        blocks: &[ParameterBlockId],
        loss: Loss,
        group: usize,
    ) -> ResidualBlockId {
        self.residuals.push(ResidualSpec {
            dim,
            blocks: blocks.to_vec(),
            loss,
            group,
        });
        ResidualBlockId(self.residuals.len() - 1)
    }

    /// Validates the description and precomputes the block structure.
    pub fn build(self) -> Result<Problem, ProblemError> {
        Problem::new(self)
    }
}

/// Where one parameter block of a residual block goes.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ResidualParam {
    /// Parameter block index.
    pub block: usize,
    /// First column of this block in the residual block's Jacobian buffer (non-constant only).
    pub col: usize,
    /// Role of the parameter block.
    pub role: BlockRole,
}

/// Precomputed structure of one residual block.
#[derive(Debug, Clone)]
pub(crate) struct ResidualLayout {
    pub dim: usize,
    /// Total Jacobian columns (sum of the dimensions of non-constant blocks).
    pub cols: usize,
    pub params: Vec<ResidualParam>,
    /// (first column, dim) per parameter block, `usize::MAX` column for constant blocks: the
    /// layout handed to the cost function.
    pub jac_layout: Vec<(usize, usize)>,
    pub loss: Loss,
    /// Rows per loss group (divides `dim`).
    pub group: usize,
    /// The eliminated block this residual depends on, if any: (eliminated index, local param
    /// index).
    pub eliminated: Option<(usize, usize)>,
    /// Reduced-reduced pairs: (local param a, local param b, offset of block (a, b) in the U
    /// values), with a's reduced index <= b's.
    pub u_targets: Vec<(usize, usize, usize)>,
    /// Reduced params coupled with the eliminated block: (local param, row offset in W_e).
    pub w_targets: Vec<(usize, usize)>,
}

/// Structure of one eliminated block.
#[derive(Debug, Clone)]
pub(crate) struct EliminatedLayout {
    /// Parameter block index.
    pub block: usize,
    pub dim: usize,
    /// Reduced blocks coupled to this block, sorted by reduced index: (reduced index, row offset
    /// in W_e). W_e is stored column-major with `w_rows` rows and `dim` columns.
    pub coupled: Vec<(usize, usize)>,
    pub w_rows: usize,
    /// Residual blocks depending on this block.
    pub residuals: Vec<usize>,
}

/// The block-sparse pattern of the reduced-reduced part `U` of the normal equations: upper
/// triangular block pairs, each stored as a dense column-major `d_a x d_b` matrix.
#[derive(Debug, Clone)]
pub(crate) struct UPattern {
    /// (reduced a, reduced b) with a <= b, and the offset of the block in the values.
    pub pairs: Vec<(usize, usize, usize)>,
    pub len: usize,
}

/// A validated problem structure, ready to be solved.
#[derive(Debug, Clone)]
pub struct Problem {
    /// Tangent dimension and offset (in the step / gradient layout) of each block.
    pub(crate) dims: Vec<usize>,
    pub(crate) offsets: Vec<usize>,
    /// Ambient dimension and offset (in the parameter vector `x`) of each block.
    pub(crate) ambient_dims: Vec<usize>,
    pub(crate) ambient_offsets: Vec<usize>,
    pub(crate) manifolds: Vec<Option<Arc<dyn Manifold>>>,
    /// True if some block has a manifold (the two layouts then differ or need `plus`).
    pub(crate) has_manifolds: bool,
    /// Length of the tangent layout.
    pub(crate) num_tangent: usize,
    pub(crate) roles: Vec<BlockRole>,
    /// Per tangent component: true if the component is held fixed (fixed component or constant
    /// block).
    pub(crate) fixed_mask: Vec<bool>,
    pub(crate) num_parameters: usize,
    pub(crate) num_free: usize,
    pub(crate) num_residuals: usize,
    /// Reduced blocks: parameter block index; offsets in the reduced vector.
    pub(crate) reduced_blocks: Vec<usize>,
    pub(crate) reduced_offsets: Vec<usize>,
    pub(crate) reduced_dim: usize,
    pub(crate) eliminated: Vec<EliminatedLayout>,
    pub(crate) residuals: Vec<ResidualLayout>,
    /// Residual blocks that depend on no eliminated block.
    pub(crate) free_residuals: Vec<usize>,
    pub(crate) u_pattern: UPattern,
    /// Largest `dim * cols` over residual blocks (Jacobian buffer size) and largest `cols`.
    pub(crate) max_jacobian_len: usize,
    pub(crate) max_cols: usize,
    pub(crate) max_residual_dim: usize,
}

impl Problem {
    fn new(builder: ProblemBuilder) -> Result<Self, ProblemError> {
        let ProblemBuilder {
            parameters,
            residuals: residual_specs,
        } = builder;
        if residual_specs.is_empty() {
            return Err(ProblemError::NoResiduals);
        }
        let mut dims = Vec::with_capacity(parameters.len());
        let mut offsets = Vec::with_capacity(parameters.len());
        let mut ambient_dims = Vec::with_capacity(parameters.len());
        let mut ambient_offsets = Vec::with_capacity(parameters.len());
        let mut manifolds = Vec::with_capacity(parameters.len());
        let mut ambient_offset = 0;
        let mut roles = Vec::with_capacity(parameters.len());
        let mut reduced_blocks = Vec::new();
        let mut reduced_offsets = Vec::new();
        let mut eliminated = Vec::new();
        let mut fixed_mask = Vec::new();
        let mut offset = 0;
        let mut reduced_dim = 0;
        for (i, p) in parameters.iter().enumerate() {
            if p.dim == 0 {
                return Err(ProblemError::EmptyParameterBlock { block: i });
            }
            let tangent = match &p.manifold {
                Some(m) => {
                    if m.ambient_dim() != p.dim || m.tangent_dim() == 0 {
                        return Err(ProblemError::ManifoldDimension {
                            block: i,
                            dim: p.dim,
                            ambient: m.ambient_dim(),
                            tangent: m.tangent_dim(),
                        });
                    }
                    m.tangent_dim()
                }
                None => p.dim,
            };
            if let Some(&c) = p.fixed.iter().find(|&&c| c >= tangent) {
                return Err(ProblemError::ComponentOutOfRange {
                    block: i,
                    dim: tangent,
                    component: c,
                });
            }
            ambient_dims.push(p.dim);
            ambient_offsets.push(ambient_offset);
            ambient_offset += p.dim;
            manifolds.push(p.manifold.clone());
            let dim = tangent;
            dims.push(dim);
            offsets.push(offset);
            offset += dim;
            let role = if p.constant {
                BlockRole::Constant
            } else if p.eliminate {
                eliminated.push(EliminatedLayout {
                    block: i,
                    dim,
                    coupled: Vec::new(),
                    w_rows: 0,
                    residuals: Vec::new(),
                });
                BlockRole::Eliminated(eliminated.len() - 1)
            } else {
                reduced_blocks.push(i);
                reduced_offsets.push(reduced_dim);
                reduced_dim += dim;
                BlockRole::Reduced(reduced_blocks.len() - 1)
            };
            roles.push(role);
            for c in 0..dim {
                fixed_mask.push(p.constant || p.fixed.binary_search(&c).is_ok());
            }
        }
        let num_tangent = offset;
        let num_parameters = ambient_offset;
        let has_manifolds = manifolds.iter().any(Option::is_some);
        let num_free = fixed_mask.iter().filter(|f| !**f).count();

        let mut residuals = Vec::with_capacity(residual_specs.len());
        let mut free_residuals = Vec::new();
        let mut pair_index: HashMap<(usize, usize), usize> = HashMap::new();
        let mut pairs: Vec<(usize, usize, usize)> = Vec::new();
        let mut u_len = 0;
        let mut max_jacobian_len = 0;
        let mut max_cols = 0;
        let mut max_residual_dim = 0;
        let mut num_residuals = 0;
        for (r, spec) in residual_specs.into_iter().enumerate() {
            if spec.dim == 0 {
                return Err(ProblemError::EmptyResidualBlock { residual: r });
            }
            let group = if spec.group == 0 {
                spec.dim
            } else {
                spec.group
            };
            if !spec.dim.is_multiple_of(group) {
                return Err(ProblemError::LossGroup {
                    residual: r,
                    dim: spec.dim,
                    group,
                });
            }
            spec.loss
                .check()
                .map_err(|reason| ProblemError::InvalidLoss {
                    residual: r,
                    reason,
                })?;
            if spec.blocks.len() > MAX_BLOCKS_PER_RESIDUAL {
                return Err(ProblemError::TooManyParameterBlocks {
                    residual: r,
                    count: spec.blocks.len(),
                });
            }
            let mut params = Vec::with_capacity(spec.blocks.len());
            let mut cols = 0;
            let mut elim: Option<(usize, usize)> = None;
            for (k, b) in spec.blocks.iter().enumerate() {
                if b.0 >= dims.len() {
                    return Err(ProblemError::UnknownParameterBlock {
                        residual: r,
                        block: b.0,
                    });
                }
                if spec.blocks[..k].contains(b) {
                    return Err(ProblemError::DuplicateParameterBlock {
                        residual: r,
                        block: b.0,
                    });
                }
                let role = roles[b.0];
                if let BlockRole::Eliminated(e) = role {
                    if let Some((first, _)) = elim {
                        return Err(ProblemError::TwoEliminatedBlocks {
                            residual: r,
                            first: eliminated[first].block,
                            second: b.0,
                        });
                    }
                    elim = Some((e, k));
                }
                params.push(ResidualParam {
                    block: b.0,
                    col: cols,
                    role,
                });
                if role != BlockRole::Constant {
                    cols += dims[b.0];
                }
            }
            // Reduced-reduced pairs.
            let mut u_targets = Vec::new();
            for (ka, pa) in params.iter().enumerate() {
                let BlockRole::Reduced(ra) = pa.role else {
                    continue;
                };
                for (kb, pb) in params.iter().enumerate() {
                    let BlockRole::Reduced(rb) = pb.role else {
                        continue;
                    };
                    if ra > rb || (ra == rb && ka != kb) {
                        continue;
                    }
                    let offset = *pair_index.entry((ra, rb)).or_insert_with(|| {
                        let o = u_len;
                        u_len += dims[reduced_blocks[ra]] * dims[reduced_blocks[rb]];
                        pairs.push((ra, rb, o));
                        o
                    });
                    u_targets.push((ka, kb, offset));
                }
            }
            // Reduced blocks coupled to the eliminated one.
            let mut w_targets = Vec::new();
            if let Some((e, _)) = elim {
                let layout = &mut eliminated[e];
                layout.residuals.push(r);
                for (k, p) in params.iter().enumerate() {
                    if let BlockRole::Reduced(ra) = p.role {
                        w_targets.push((k, ra));
                        if !layout.coupled.iter().any(|&(c, _)| c == ra) {
                            layout.coupled.push((ra, 0));
                        }
                    }
                }
            } else {
                free_residuals.push(r);
            }
            let jac_layout = params
                .iter()
                .map(|p| {
                    let col = if p.role == BlockRole::Constant {
                        usize::MAX
                    } else {
                        p.col
                    };
                    (col, dims[p.block])
                })
                .collect();
            max_jacobian_len = max_jacobian_len.max(spec.dim * cols);
            max_cols = max_cols.max(cols);
            max_residual_dim = max_residual_dim.max(spec.dim);
            num_residuals += spec.dim;
            residuals.push(ResidualLayout {
                dim: spec.dim,
                cols,
                params,
                jac_layout,
                loss: spec.loss,
                group,
                eliminated: elim,
                u_targets,
                // Temporarily holds reduced indices; turned into row offsets below.
                w_targets,
            });
        }
        // Row offsets of the coupled reduced blocks inside each W_e.
        for layout in &mut eliminated {
            layout.coupled.sort_unstable();
            let mut rows = 0;
            for entry in &mut layout.coupled {
                entry.1 = rows;
                rows += dims[reduced_blocks[entry.0]];
            }
            layout.w_rows = rows;
        }
        for res in &mut residuals {
            if let Some((e, _)) = res.eliminated {
                let coupled = &eliminated[e].coupled;
                for t in &mut res.w_targets {
                    let ra = t.1;
                    let pos = coupled.binary_search_by_key(&ra, |c| c.0).unwrap_or(0);
                    t.1 = coupled[pos].1;
                }
            }
        }
        Ok(Problem {
            dims,
            offsets,
            ambient_dims,
            ambient_offsets,
            manifolds,
            has_manifolds,
            num_tangent,
            roles,
            fixed_mask,
            num_parameters,
            num_free,
            num_residuals,
            reduced_blocks,
            reduced_offsets,
            reduced_dim,
            eliminated,
            residuals,
            free_residuals,
            u_pattern: UPattern { pairs, len: u_len },
            max_jacobian_len,
            max_cols,
            max_residual_dim,
        })
    }

    /// Total number of parameters (length of the flat parameter vector), constant ones included.
    pub fn num_parameters(&self) -> usize {
        self.num_parameters
    }

    /// Length of the tangent layout (steps, gradients, fixed components): the number of
    /// parameters unless some block has a manifold with fewer degrees of freedom than values.
    pub fn num_tangent_parameters(&self) -> usize {
        self.num_tangent
    }

    /// Number of parameters actually optimized (not constant, not fixed; tangent components).
    pub fn num_free_parameters(&self) -> usize {
        self.num_free
    }

    /// Total number of scalar residuals.
    pub fn num_residuals(&self) -> usize {
        self.num_residuals
    }

    /// Number of parameter blocks.
    pub fn num_parameter_blocks(&self) -> usize {
        self.dims.len()
    }

    /// Number of residual blocks.
    pub fn num_residual_blocks(&self) -> usize {
        self.residuals.len()
    }

    /// Dimension of a parameter block (number of values in `x`).
    pub fn dim(&self, block: ParameterBlockId) -> usize {
        self.ambient_dims[block.0]
    }

    /// Offset of a parameter block in the flat parameter vector `x`.
    pub fn offset(&self, block: ParameterBlockId) -> usize {
        self.ambient_offsets[block.0]
    }

    /// Degrees of freedom of a parameter block (its manifold's tangent dimension, else `dim`).
    pub fn tangent_dim(&self, block: ParameterBlockId) -> usize {
        self.dims[block.0]
    }

    /// Offset of a parameter block in the tangent layout (steps, gradients, fixed components).
    pub fn tangent_offset(&self, block: ParameterBlockId) -> usize {
        self.offsets[block.0]
    }

    /// The values of one block inside the flat parameter vector `x`.
    pub fn block<'a>(&self, x: &'a [f64], block: ParameterBlockId) -> &'a [f64] {
        let o = self.ambient_offsets[block.0];
        &x[o..o + self.ambient_dims[block.0]]
    }

    /// Mutable values of one block inside the flat parameter vector `x`.
    pub fn block_mut<'a>(&self, x: &'a mut [f64], block: ParameterBlockId) -> &'a mut [f64] {
        let o = self.ambient_offsets[block.0];
        &mut x[o..o + self.ambient_dims[block.0]]
    }

    /// Writes `x ⊞ step` into `out`: `x + step` for Euclidean blocks, [`Manifold::plus`] for the
    /// others (`x`, `out`: parameter layout; `step`: tangent layout).
    pub fn plus(&self, x: &[f64], step: &[f64], out: &mut [f64]) {
        if !self.has_manifolds {
            for ((o, a), b) in out.iter_mut().zip(x).zip(step) {
                *o = a + b;
            }
            return;
        }
        for (b, manifold) in self.manifolds.iter().enumerate() {
            let (ao, ad) = (self.ambient_offsets[b], self.ambient_dims[b]);
            let (to, td) = (self.offsets[b], self.dims[b]);
            let (xb, sb, ob) = (&x[ao..ao + ad], &step[to..to + td], &mut out[ao..ao + ad]);
            match manifold {
                Some(m) => m.plus(xb, sb, ob),
                None => {
                    for ((o, a), d) in ob.iter_mut().zip(xb).zip(sb) {
                        *o = a + d;
                    }
                }
            }
        }
    }

    /// Dimension of the reduced system (sum of the dimensions of non-constant, non-eliminated
    /// blocks, fixed components included).
    pub fn reduced_dim(&self) -> usize {
        self.reduced_dim
    }

    /// Number of eliminated blocks.
    pub fn num_eliminated_blocks(&self) -> usize {
        self.eliminated.len()
    }

    /// True if component `i` of the tangent layout is held fixed (constant block or fixed
    /// component); without manifolds the tangent layout is the parameter layout.
    pub fn is_fixed(&self, i: usize) -> bool {
        self.fixed_mask[i]
    }

    /// Dimension of residual block `r`.
    pub fn residual_dim(&self, r: ResidualBlockId) -> usize {
        self.residuals[r.0].dim
    }

    /// The parameter blocks residual block `r` depends on, in the order given when it was added.
    pub fn residual_blocks_of(
        &self,
        r: ResidualBlockId,
    ) -> impl Iterator<Item = ParameterBlockId> + '_ {
        self.residuals[r.0]
            .params
            .iter()
            .map(|p| ParameterBlockId(p.block))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn structure_of_a_calibration_like_problem() {
        let mut b = ProblemBuilder::new();
        let intr = b.add_parameter_block(8);
        let poses: Vec<_> = (0..3).map(|_| b.add_parameter_block(6)).collect();
        for &p in &poses {
            b.set_eliminated(p, true);
            b.add_residual_block(10, &[intr, p]);
        }
        let problem = b.build().unwrap();
        assert_eq!(problem.reduced_dim(), 8);
        assert_eq!(problem.num_eliminated_blocks(), 3);
        assert_eq!(problem.u_pattern.pairs.len(), 1);
        assert_eq!(problem.u_pattern.len, 64);
        assert_eq!(problem.eliminated[1].w_rows, 8);
        assert_eq!(problem.residuals[2].cols, 14);
        assert_eq!(problem.num_residuals(), 30);
        assert_eq!(problem.offset(poses[2]), 8 + 12);
    }

    #[test]
    fn invalid_descriptions_are_reported() {
        let mut b = ProblemBuilder::new();
        let a = b.add_parameter_block(2);
        let c = b.add_parameter_block(2);
        b.set_eliminated(a, true);
        b.set_eliminated(c, true);
        b.add_residual_block(1, &[a, c]);
        assert!(matches!(
            b.build(),
            Err(ProblemError::TwoEliminatedBlocks { residual: 0, .. })
        ));

        let mut b = ProblemBuilder::new();
        let a = b.add_parameter_block(2);
        b.add_residual_block(1, &[a, a]);
        assert!(matches!(
            b.build(),
            Err(ProblemError::DuplicateParameterBlock { .. })
        ));

        let mut b = ProblemBuilder::new();
        b.add_parameter_block(2);
        b.add_residual_block(1, &[ParameterBlockId(5)]);
        assert!(matches!(
            b.build(),
            Err(ProblemError::UnknownParameterBlock { block: 5, .. })
        ));

        let mut b = ProblemBuilder::new();
        let a = b.add_parameter_block(2);
        b.set_fixed_components(a, &[2]);
        b.add_residual_block(1, &[a]);
        assert!(matches!(
            b.build(),
            Err(ProblemError::ComponentOutOfRange { component: 2, .. })
        ));

        let mut b = ProblemBuilder::new();
        b.add_parameter_block(0);
        assert!(matches!(b.build(), Err(ProblemError::NoResiduals)));
        let mut b = ProblemBuilder::new();
        let a = b.add_parameter_block(0);
        b.add_residual_block(1, &[a]);
        assert!(matches!(
            b.build(),
            Err(ProblemError::EmptyParameterBlock { block: 0 })
        ));
        let mut b = ProblemBuilder::new();
        let a = b.add_parameter_block(1);
        b.add_residual_block(0, &[a]);
        assert!(matches!(
            b.build(),
            Err(ProblemError::EmptyResidualBlock { residual: 0 })
        ));
    }
}
