// Placeholder translation unit until the module gains its first source file.
namespace lightskin::gi {}
