"""hpddo tools: bench log I/O, the bench twin, identification, training, export, diagnosis."""
