"""Test scaffolding shared by the tests: shared data lookup and the Mapper's drives."""
