"""Advisory stage: sensitivity level selection and the TA/RA state machines (TCAS II v7.1 logic)."""
