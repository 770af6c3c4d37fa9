"""The report's section on the literature since 2005 (written into every REPORT.md).

Every reference was checked against a stored copy of its abstract, arXiv page or
publisher record; what could not be checked is not cited. Numbers are not repeated here:
the text points to the verdict rows above, so that a rerun cannot leave it behind.
Statements marked *(our remark)* are the project's inferences, not the cited authors'.
"""

LITERATURE = """\
## Related work since 2005

**Force-network ensembles.** Snoeijer, Vlugt, Ellenbroek, van Hecke and van Leeuwen [2]
built a statistical ensemble for the forces of a static packing: the contact geometry is
held fixed and every force network that is repulsive and balances every particle gets
equal weight, an a-priori flat measure on the admissible region of force space, from which
they derived the force distribution P(f). Van Eerd et al. [3] sampled this measure for
frictionless packings by umbrella sampling and found P(f) falling faster than exponentially;
Tighe et al. [4] used the same uniform weighting on a lattice of rigid bars, and Tighe, van
Eerd and Vlugt [5] maximised its entropy with and without friction. The set S of this
report is the frictional rigid-disk version of that admissible region at fixed geometry and
boundary loads, and our uniform samplers (hit-and-run, the billiard walk) draw from the
flat measure those works postulate. Unger, Kertész and Wolf [1] tested the equal-
probability assumption with their perturb-and-relax walk.

**What our results say about the flat measure.** The perturb-and-relax walk is not a
uniform sampler of S (fig3, the uniformity row): its samples sit on Coulomb faces and its
eta is several times the uniform one. The paper's Fig. 3 therefore tests the walk, not the
flat measure: with the walk's own centre we reproduce "closer to the centre", with the
centre of the uniform measure the jammed network lies *farther* from it than typical
networks (fig3, the two centrality rows). The conclusion that the realised network is not
a typical draw from the flat measure survives; the picture of a "more central" network does
not. *(our remark)* Under any measure with a density on S, the flat one included, a contact
sits exactly at its Coulomb limit with probability zero unless it does so everywhere in S;
a network with fully mobilised contacts lies on a set of measure zero and is atypical by
construction. For contact-dynamics packings, observables that depend on mobilisation (the
fraction of contacts at the Coulomb limit, the distribution of |f_t| / mu f_n, distances
from the centre) cannot be predicted from the flat measure; observables blind to this fine
structure (P(f) when eta is small) are not tested by our data.

**Mobilisation and generalised isostaticity.** McNamara and Herrmann [6] showed for
perfectly rigid disks that the admissible contact forces form a convex set whose boundary
is tied to sliding contacts, so that a stable 2-D packing has at most 2M - 3N sliding
contacts (M contacts, N particles). *(our algebra)* With z = 2M / N this reads
z >= 3 + n_m, n_m the sliding contacts per particle; equality is the marginal,
"generalised isostatic" case that Henkes, van Hecke and van Saarloos [7] use to describe
jamming of frictional grains, treating contacts at the Coulomb threshold as slipping. The
fig1 study reports the mobilised fraction beside z for this comparison.

**Ways to measure indeterminacy.** McNamara and Herrmann [6] measured how far each force
component can vary within the set and estimated its diameter (the most indeterminate
contacts lie on force chains). Those depend on S alone, whereas eta also depends on the
sampler (fig3); we therefore report uniform eta beside the exact analysis of S. The size
question the paper left open (eta against n) is, as far as we found, unanswered in print.

**Protocol dependence.** Bililign, Kollmer and Daniels [8] loaded 2-D photoelastic packings
in three ways and argued from coarse-grained force-moment statistics that a stress ensemble
must conserve both the force-moment tensor and the force-tile area. Within one S (fixed
geometry and loads) we find protocol dependence at a finer level: the relax walk,
contact-dynamics jamming and elastic DEM select different networks (fig3, selection).
The elastic selection is in line with Olsen and Kamrin [9], who pick the stiff-limit DEM
network out of the indeterminate contact-dynamics solutions by imposing elastic
compatibility, and with McNamara and Herrmann's argument [10] that quasi-rigidity gives
unique predictions for disks.

**References** (each checked against its abstract or record; where a journal reference
could not be checked it is left out)

1. T. Unger, J. Kertész, D. E. Wolf, Force indeterminacy in the jammed state of hard disks,
   Phys. Rev. Lett. 94, 178001 (2005).
2. J. H. Snoeijer, T. J. H. Vlugt, W. G. Ellenbroek, M. van Hecke, J. M. J. van Leeuwen,
   Ensemble theory for force networks in hyperstatic granular matter, Phys. Rev. E 70,
   061306 (2004); arXiv:cond-mat/0407027.
3. A. R. T. van Eerd, W. G. Ellenbroek, M. van Hecke, J. H. Snoeijer, T. J. H. Vlugt, Tail
   of the contact force distribution in static granular materials, Phys. Rev. E 75,
   060302(R) (2007).
4. B. P. Tighe, J. E. S. Socolar, D. G. Schaeffer, W. G. Mitchener, M. L. Huber, Force
   distributions in a triangular lattice of rigid bars, Phys. Rev. E 72, 031306 (2005).
5. B. P. Tighe, A. R. T. van Eerd, T. J. H. Vlugt, Entropy maximization in the force
   network ensemble for granular solids, arXiv:0803.0907 (Phys. Rev. Lett.; volume and
   page not checked).
6. S. McNamara, H. Herrmann, Measurement of indeterminacy in packings of perfectly rigid
   disks, Phys. Rev. E 70, 061303 (2004); arXiv:cond-mat/0404297.
7. S. Henkes, M. van Hecke, W. van Saarloos, Critical jamming of frictional grains in the
   generalized isostaticity picture, arXiv:0907.3451.
8. E. S. Bililign, J. E. Kollmer, K. E. Daniels, Protocol dependence and state variables in
   the force-moment ensemble, Phys. Rev. Lett. 122, 038001 (2019).
9. T. Olsen, K. Kamrin, Resolving force indeterminacy in contact dynamics using
   compatibility conditions, arXiv:1805.07437.
10. S. C. McNamara, H. J. Herrmann, Quasi-rigidity: some uniqueness issues,
    arXiv:cond-mat/0603761.
"""
