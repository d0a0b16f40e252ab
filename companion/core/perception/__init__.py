"""What a depth camera sees as landmark observations, and the map back as proximity sectors."""
