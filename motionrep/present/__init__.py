"""The presentation wing: what people look at.

File descriptions (``info``), the HTML viewer, rendered animations and filmstrips, and the codec benchmark."""
