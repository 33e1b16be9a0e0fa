This is a plain text note, not XML.
Building heights were measured on site; see the attached spreadsheet.
3 buildings, 2 garages.
