"""The photon records and blocks (paper sections 3.2, 4.1, Figure 4): 32-bit fixed-point
positions (:mod:`.fixedpoint`), six-word records (:mod:`.codec`), Hilbert keys (:mod:`.hilbert`)
and their stable radix sort (:mod:`.radixsort`), octahedral unit vectors (:mod:`.octahedral`,
the cover gather's records), the B+-tree and the bulk build of 64-word
blocks (:mod:`.btree`, :mod:`.blocks`)."""
