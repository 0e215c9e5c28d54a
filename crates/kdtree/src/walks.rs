//! The kd traversals as one list ([`kd_walks!`]): the kd-tree's table and multi-kd's rows and
//! per-ray dispatch are generated from it, so a traversal added to the list (its walk in a
//! file of its own) is offered by both without further edits.

/// Every kd traversal in the kd table's order: `$m! { entries }`, each entry
///
/// ```text
/// "name", "paper", "doc", [info modifiers], gpu [GPU program fn, or nothing],
///     |t, w| kernel;
/// ```
///
/// the config name, the one-line paper reference and the doc of its
/// [`tb_core::TraversalInfo`] (the modifiers are applied to it: `.capped()`, `.reads(..)`),
/// the kd-tree's GPU program where it has one, and the CPU kernel: an expression of the
/// structure `t` (a [`crate::KdTree`], or a structure over kd-trees with the same
/// `back_nodes()` and `ropes()`: multi-kd) and of the walk's input `w` (a
/// [`crate::traverse::Tree`]). Tokens after a `;` (`kd_walks!(m; more entries)`) are
/// appended to the list: a test adds a dummy traversal so.
#[macro_export]
macro_rules! kd_walks {
    ($m:ident $(; $($more:tt)*)?) => {
        $m! {
            "recursive-direction", "Hapala & Havran 2011 §3.2, Alg. 2",
            "stack-based, near/far child by the sign of the ray direction, entry/exit \
             distances on the stack (Keller 1997, Wald 2004; Hapala & Havran 2011 §3.2, \
             Alg. 2); zero direction components handled by the sign of the zero (no \
             epsilon)",
            [], gpu [$crate::KdTree::gpu_recursive],
            |t, w| $crate::traverse::RecursiveDirection(w);
            "havran", "Hapala & Havran 2011 §3.2; Havran 2000 App. C",
            "Havran's robust TA^B_rec: entry/exit points on the stack, near/far decided by \
             comparing point coordinates with the split (Havran 2000; Hapala & Havran 2011 \
             §3.2); rays lying in a split plane visit both children",
            [], gpu [],
            |t, w| $crate::traverse::Havran(w);
            "recursive-origin", "Hapala & Havran 2011 §3.2, Alg. 2",
            "stack-based, near/far child by the side of the split plane holding the ray \
             origin (Jansen 1986, Arvo 1988; Hapala & Havran 2011 §3.2, Alg. 2): \
             inherently not robust for origins in a split plane (Havran et al. 1997)",
            [], gpu [],
            |t, w| $crate::traverse::RecursiveOrigin(w);
            "restart", "Hapala & Havran 2011 §5.1",
            "stackless kd-restart: after each leaf restart at the root with the entry \
             distance set to the leaf's exit (Foley & Sugerman 2005; Hapala & Havran 2011 \
             §5.1), t-intervals and exact comparisons, no epsilon step",
            [.capped()], gpu [$crate::KdTree::gpu_restart],
            |t, w| $crate::stackless::StacklessKernel::<_, { $crate::stackless::RESTART }>(
                w,
                $crate::view::Aux::default(),
            );
            "push-down", "Hapala & Havran 2011 §5.2, Alg. 4",
            "kd-push-down: restart at the deepest node holding the whole remaining segment \
             (Horn et al. 2007; Hapala & Havran 2011 §5.2, Alg. 4)",
            [.capped()], gpu [$crate::KdTree::gpu_push_down],
            |t, w| $crate::stackless::StacklessKernel::<_, { $crate::stackless::PUSH_DOWN }>(
                w,
                $crate::view::Aux::default(),
            );
            "short-stack", "Hapala & Havran 2011 §5.2",
            "push-down with a circular short stack of `short_stack` far children, \
             restarting from the pushed-down node when it runs dry (Horn et al. 2007; \
             Hapala & Havran 2011 §5.2)",
            [.capped()], gpu [$crate::KdTree::gpu_short_stack],
            |t, w| $crate::stackless::StacklessKernel::<_, { $crate::stackless::SHORT_STACK }>(
                w,
                $crate::view::Aux::default(),
            );
            "sequential", "Hapala & Havran 2011 §3.1, Alg. 1",
            "Kaplan's sequential traversal: locate the leaf holding the ray point at the \
             entry distance from the root, leave it through its cell's exit (Kaplan 1985; \
             Hapala & Havran 2011 §3.1, Alg. 1), no epsilon step: crossed faces' \
             coordinates exact, rays a point cannot decide (edges, corners) handed to \
             `restart`",
            [.capped()], gpu [$crate::KdTree::gpu_sequential],
            |t, w| $crate::stackless::StacklessKernel::<_, { $crate::stackless::SEQUENTIAL }>(
                w,
                $crate::view::Aux::default(),
            );
            "backtrack", "Hapala & Havran 2011 §5.1.1, Alg. 3",
            "kd-backtrack: parent links and node cells in an auxiliary array; from a leaf \
             climb until a cell extends beyond the leaf's exit, then descend (Foley & \
             Sugerman 2005; Hapala & Havran 2011 §5.1.1, Alg. 3)",
            [.capped() .reads(&[$crate::BACKTRACK_AUX])], gpu [$crate::KdTree::gpu_backtrack],
            |t, w| $crate::stackless::StacklessKernel::<_, { $crate::stackless::BACKTRACK }>(
                w,
                $crate::view::Aux { back: t.back_nodes(), ropes: None },
            );
            "ropes", "Hapala & Havran 2011 §3.3",
            "neighbour links: from a leaf follow the pushed-down rope of its exit face \
             (cell and six ropes per leaf in an auxiliary array) and locate the next \
             leaf below it (MacDonald & Booth 1990, Havran et al. 1998, Popov et al. 2007; \
             Hapala & Havran 2011 §3.3)",
            [.capped() .reads(&[$crate::ROPES_AUX])], gpu [$crate::KdTree::gpu_ropes],
            |t, w| $crate::stackless::StacklessKernel::<_, { $crate::stackless::ROPES }>(
                w,
                $crate::view::Aux { back: &[], ropes: Some(t.ropes()) },
            );
            "branchless", "Hapala & Havran 2011 §5.5, Alg. 5",
            "recursive-direction with a branchless node step: far and near written to the \
             stack, the pointer moved by the two comparisons (Hapala 2009; Hapala & Havran \
             2011 §5.5, Alg. 5)",
            [], gpu [],
            |t, w| $crate::traverse::Branchless(w);
            "stack-spilling", "Hapala & Havran 2011 §5.2, Fig. 8",
            "short circular stack of `short_stack` entries whose oldest entry is spilled to \
             a full memory stack on overflow and refilled on underflow, never restarting \
             (Novák 2009; Hapala & Havran 2011 §5.2, Fig. 8)",
            [], gpu [],
            |t, w| $crate::traverse::StackSpilling(w);
            $($($more)*)?
        }
    };
}
