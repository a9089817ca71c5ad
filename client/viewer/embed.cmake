# Writes OUT, a C header defining `static const unsigned char NAME[]` with
# the bytes of IN and a terminating NUL, so that the viewer's GLSL lives in
# its own files and reaches the binary unchanged.
# usage: cmake -DIN=file -DOUT=header -DNAME=symbol -P embed.cmake
file(READ ${IN} hex HEX)
string(LENGTH "${hex}" n)
set(body "")
set(i 0)
while(i LESS n)
  string(SUBSTRING "${hex}" ${i} 2 byte)
  string(APPEND body "0x${byte},")
  math(EXPR i "${i} + 2")
  math(EXPR col "${i} % 32")
  if(col EQUAL 0)
    string(APPEND body "\n")
  endif()
endwhile()
get_filename_component(src ${IN} NAME)
file(WRITE ${OUT} "/* Generated from ${src} by embed.cmake; do not edit. */\n"
  "static const unsigned char ${NAME}[] = {\n${body}0x00};\n")
