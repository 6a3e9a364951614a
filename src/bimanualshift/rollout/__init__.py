"""The one closed-loop rollout: a policy acting keyframe by keyframe in a task's environment. Evaluation, the
benchmark's workers, the prior report, the demo and refinement all roll out through it."""
