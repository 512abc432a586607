// Precompiled for every test driver (Makefile: TEST_PCH): GoogleTest and the standard headers most
// drivers include. Parsing them was about a third of a test driver's compile time at -O1 -g1; each
// driver still includes what it uses, so it also builds without this header.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>
