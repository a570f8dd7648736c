"""Generation: planning episodes, making one episode, running many."""
