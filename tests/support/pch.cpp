// The source of dtflop_test_pch: the precompiled header every test executable reuses
// (tests/CMakeLists.txt). It holds nothing itself.
