"""tyrebayes.physics."""
