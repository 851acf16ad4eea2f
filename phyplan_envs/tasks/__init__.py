"""The four phyplan tasks, one short file each."""
