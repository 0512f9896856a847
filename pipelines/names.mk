# names.mk — the file names a pipeline may paste into a recipe, a prerequisite or a $(shell).
#
# Make has no quoting: a name is pasted into the shell lines of the recipes as it is, and make
# itself splits target and prerequisite names at spaces and reads ':', '=', '%' and '#' in them.
# So a name that comes from a user variable (SCENE, SCENE_BAKE_OPTIONS) and ends up in a recipe
# must hold only characters that mean nothing to make or to the shell:
#
#   A-Z a-z 0-9 . _ / + ~ @ , -      and not start with '-' (it would read as an option)
#
# Anything else (a space, tab or newline, a quote, ; $ ` & | < > ( ) * ? [ ] { } \ ! # % : = ^ or
# a byte outside ASCII) stops make with one line before any recipe or $(shell) runs; such a scene
# renders without make: build/bin/render --scene FILE -o image.exr (render takes the name as one
# argument and never hands it to a shell), or after renaming it.
#
# $(call pf_check_name,VARIABLE) checks the variable's unexpanded text ($(value ...): a '$' in it
# is refused, not expanded) and expands to nothing; the message quotes the name with any newline
# shown as \n, so the refusal is one line, and make prints it without a shell.

pf_comma := ,
define pf_newline


endef
pf_name_chars := a b c d e f g h i j k l m n o p q r s t u v w x y z \
  A B C D E F G H I J K L M N O P Q R S T U V W X Y Z 0 1 2 3 4 5 6 7 8 9 . _ / + ~ @ $(pf_comma) -
# $(1) with every character of the list $(2) removed.
pf_strip_chars = $(if $(2),$(call pf_strip_chars,$(subst $(firstword $(2)),,$(1)),$(wordlist 2,$(words $(2)),$(2))),$(1))
# "bad" when the text $(1) is empty, holds whitespace (a space, tab or newline makes more than
# one word; a newline alone is whitespace to make), starts with '-', or holds a character outside
# pf_name_chars.
pf_bad_name = $(if $(filter-out 1,$(words $(1))),bad,$(if $(filter -%,$(1)),bad,$(if $(findstring $(pf_newline),$(1)),bad,$(if $(call pf_strip_chars,$(1),$(pf_name_chars)),bad))))
pf_check_name = $(if $(call pf_bad_name,$(value $(1))),$(error $(1)='$(subst $(pf_newline),\n,$(value $(1)))' is not a name make can pass safely to the tools: use only A-Z a-z 0-9 . _ / + ~ @ $(pf_comma) - and no leading - (docs/SCENES.md); rename the file, or run build/bin/render --scene FILE -o image.exr directly))
