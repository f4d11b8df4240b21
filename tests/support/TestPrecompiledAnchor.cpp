// The program that owns the test programs' precompiled header (tests/CMakeLists.txt). Never run.
int main() { return 0; }
