/* The C side of the tests' shared precompiled header (tests/CMakeLists.txt). */
typedef int palp_test_pch_c_side;
