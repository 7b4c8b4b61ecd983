// The translation unit that builds the tests' shared precompiled header (tests/CMakeLists.txt,
// PALP_TEST_PCH); it holds no code of its own.
