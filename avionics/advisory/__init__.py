"""Advisory stage: sensitivity level selection, the alerter (TA and RA as the tcas2 alerter's levels), alert gating and
persistence, and the TA/RA state machines (TCAS II v7.1 logic)."""
