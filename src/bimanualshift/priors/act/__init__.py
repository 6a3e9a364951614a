"""ACT (Action Chunking with Transformers) as a network the baselines train from scratch."""
