"""tyrebayes.inference."""
