"""The paper's figure captions, LaTeX lightly cleaned (copied from the .tex)."""

from __future__ import annotations

__all__ = ["CAPTIONS"]


#: The paper's captions, LaTeX lightly cleaned (copied from the .tex).
CAPTIONS: dict[str, str] = {
    "fig:setup": "Setup for synthetic aperture imaging.",
    "fig:hyperbola": "Left: Pulse compressed data D_p(s,t) = f(t - τ(s,ρ)) from a target at "
    "ρ = (0,5,0) m, recorded by a SAR antenna moving at speed V = 70 m/s along a linear "
    "aperture of 400 m, at range L = 10 km from ρ. Right: Range-compressed data D_r(s,t') "
    "with respect to ρ_o = (0,0,0) m.",
    "fig:imageComp": "Left: The image of the complex Scene 1, with twenty stationary targets "
    "and two moving targets. Right: Image of the same stationary scene, and no moving "
    "targets. The effect of the moving targets in the left image amounts to two faint "
    "streaks.",
    "fig:straightTrace": "Left: The trace |D_r(s,t)| from one stationary target. Right: the "
    "traces after the travel time transformation relative to the exact location of the "
    "target. Note that there is no dependence on s after the transformation.",
    "fig:rotScatt": "Left: The traces D_r(s,t) for a scene with one stationary target at "
    "location ρ and a moving one at 28 m/s. Middle: The traces after the travel time "
    "transformation [T_+^ρ D_r](s,t). Right: The filtered traces [Q^{ρ^e} D_r](s,t).",
    "fig:dataDecomp": "Left: The matrix M of the sampled traces from Scene 1. Middle: The "
    "matrix L consisting of the traces from the stationary targets in Scene 1. Right: The "
    "matrix S consisting of the traces from the moving targets in Scene 1.",
    "fig:rpcaEx1": "Separation of traces from the scene in Example 1. From left to right we "
    "show the matrix M of traces, the low rank L, and sparse S components obtained with "
    "robust PCA. Top row: robust PCA applied to the entire data matrix M. Bottom row: "
    "robust PCA applied to a windowed M. In each plot the matrices are normalized by the "
    "largest value of |M|. The sparse components shown in the right column are plotted in "
    "(decibel) dB scale to make the contrast more visible.",
    "fig:rpcaEx2a": "Matrix M of traces from the scene in Example 2.",
    "fig:rpcaEx2b": "Robust PCA separation of traces from a scene with thirty stationary "
    "targets and one moving target. The top row of plots shows the results with robust PCA "
    "applied to the entire data matrix in Figure fig:rpcaEx2a. The low rank and sparse "
    "components are shown on the left and right, respectively. The bottom row of plots "
    "shows the results with robust PCA applied to successive small time windows of the "
    "data. The sparse components shown in the right column are plotted in dB scale to make "
    "the contrast more visible.",
    "fig:annihilScene1": "Annihilation with the filter (eq:OP2) of the stationary target "
    "traces from Scene 1. Top: the matrix of traces. Bottom: the filtered traces. In each "
    "plot we show absolute values normalized by the largest value of |M|. The right column "
    "is the left column plotted in dB scale.",
    "fig:rpca2mov": "Trace separation with robust PCA for Scene 1. The low rank part L is "
    "shown on the left and the sparse part S is shown on the right. In each plot we show "
    "absolute values normalized by the largest value of |M|. The sparse part is plotted in "
    "dB scale.",
    "fig:rotateTrueFilt": "Left: The traces from the two moving targets in Scene 1. Middle "
    "and right: The transformed traces T_+^{u,ρ} D_r(s,t) for the first and second target.",
    "fig:filtComp": "The objective function g(u) using the traces from the entire Scene 1 "
    "(left) and the traces from the moving targets in Scene 1 (right).",
    "fig:rotate2stage": "Top row: The traces after the travel time transformation (eq:TTu+) "
    "at the estimated range speed of one target. Bottom row: The traces after the travel "
    "time transformation (eq:TTu+) with the estimated cross-range correction of the speed. "
    "The right column is a zoom of the left column.",
    "fig:objfxns": "Left: The objective function g. Middle and right: The objective function "
    "g_⊥ for the estimated range speeds of the two targets in Scene 1. The minima of g_⊥ "
    "are the estimates of u_⊥.",
    "fig:rank1": "Comparison of the computed and estimated rank of Y for a single target. "
    "Left: Stationary target at various cross-range positions. Right: Moving target with "
    "various velocities.",
    "fig:convergeRank": "Convergence of the rank of Y normalized by the size (n+1). The blue "
    "line is the computed value and the green line is the asymptotic estimate. The slow "
    "time sampling is fixed, so the longer the aperture is, the larger n.",
    "fig:eigenvals2": "Computed and estimated rank of matrix Y for a scene with two "
    "stationary targets. On the left, one target is fixed at location ρ_1 = (5,5,0) m and "
    "the location of the other varies on the line segment between (-5,0.01,0) m and "
    "(-5,30,0) m. On the right, one target is fixed at location ρ_1 = (0.15,5,0) m and the "
    "location of the other varies on the line segment between (-0.15,0.01,0) m and "
    "(-0.15,30,0) m.",
    "fig:filter10scatt1ord": "Data separation with the annihilation filter for a scene with "
    "ten stationary targets and a moving one. The top row shows the data traces and the "
    "bottom row the trace from the moving target, as separated by the algorithm. The right "
    "column is the left column plotted in dB scale.",
    "fig:filter30scatt1ord": "Data separation with the annihilation filter for a scene with "
    "thirty stationary targets and a moving one. The top row shows the data traces and the "
    "bottom row the trace from the moving target, as separated by the algorithm. The right "
    "column is the left column plotted in dB scale.",
    "fig:motEstscatt": "Error of the estimated target trajectory in a complex scene with ten "
    "stationary targets (left) and thirty stationary targets (right). The motion estimation "
    "is done with the filtered data shown in the bottom row of Figures "
    "fig:filter10scatt1ord and fig:filter30scatt1ord.",
    "fig:rpca2movFinalSep": "Data separation for Scene 1. Left: traces from the stationary "
    "targets. Middle and right: traces from the moving targets.",
    "fig:sepImgs": "Images for Scene 1. Left: image with the traces from the stationary "
    "targets. Middle and right: image with the traces the moving targets.",
}
