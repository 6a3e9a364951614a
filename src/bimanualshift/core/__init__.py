"""What every layer shares and nothing heavy is imported for: the policy protocol, the arm names and the
vocabulary of colours and goal nouns."""
